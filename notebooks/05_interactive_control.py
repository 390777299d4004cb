# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% tags=["parameters"]
QUICK = True            # quick: a 10 s scripted session (CI); full: 30 s and the live control
MODEL = "ccnet_generate"  # the recommended generator (the generate command's model)
FIG_DIR = "../figures"

# %% [markdown]
# # 05 · Interactive control of CCNet (§4.4)
#
# The paper drives CCNet from a keyboard: **number keys** pick the motion type (the label moves
# from the old type to the new one over 20 frames), **up/down** change the speed (over 20
# frames the predicted trajectory is rescaled from the current speed $v_{cur}$ to the user's
# $v_u$), and **left/right** bend the predicted trajectory control $\hat{\mathbf c}^d_n$: an
# offset $\mathbf o_n=[1,0]\,h\,0.015$ ($h$ the root height) is added to its six points with
# weights $w_i=i/5,\ i=0..5$. Without keys, the network's own predicted $\hat{\mathbf c}^d$ is fed
# back (the direction-control term of Eq. 10 exists for this).
#
# Here the keys are a **pure function** (`mocapviz.tasks.control.plan_controls`): a scripted key
# stream becomes per-frame controls, which a step-level generator (`ControlSession`) applies
# between frames. The same code runs behind the live JupyterLab control at the end.
# The paper reports no numbers for this demo (a video only), so we measure what the keys do to
# the generated root path.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import torch

from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from data_prep.sources import REPO_ROOT
from mocapviz.features.ccnet import features_to_motion
from mocapviz.features.motion_types import MOTION_TYPES, one_hot
from mocapviz.heading import from_heading_frame_xz
from mocapviz.io.bvh import write_bvh
from mocapviz.tasks.control import KEY_TYPES, ControlSession, KeyEvent, hold, path_speed, plan_controls
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.viz import scene
from mocapviz.zoo import find_checkpoint

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
print("pyvista backend:", scene.set_notebook_backend(QUICK))
model, norm, meta = load_checkpoint(find_checkpoint(MODEL, cwd=REPO_ROOT))
ds = build_dataset(DatasetConfig.quick(), progress=False)
print(MODEL, "types:", model.cfg.n_types, "| keys:", KEY_TYPES)

# %% [markdown]
# ## 1 · A scripted key stream and its per-frame controls
#
# Seed: the first 120 frames (2 s) of a walking clip of the test split. Then: walk on, hold
# **left** for 2 s, press **up** twice, switch to **2 (jog)**, hold **right** for 2 s.

# %%
n_frames = 600 if QUICK else 1800
script = (hold("left", 60, 120) + [KeyEvent(220, "up"), KeyEvent(221, "up")] + [KeyEvent(300, "2")]
          + hold("right", 400, 120))
row = int(np.flatnonzero((ds.clips.split == "test") & (ds.clips.type == "walk")
                         & (ds.clips.stop - ds.clips.start > 130))[0])
clip, seed = ds.clips.iloc[row], ds.clip_arrays(row)
start = ((clip.root_x, clip.root_y, clip.root_z), clip.heading)


def new_session():
    return ControlSession(model, norm, seed["x"][:120], seed["traj"][:120], seed["skel"],
                          one_hot(seed["type_index"], model.cfg.n_types))


session = new_session()
v0 = float(path_speed(session.predicted_traj()))
plan = plan_controls(script, n_frames, seed["type_index"], model.cfg.n_types, start_speed=v0)
print(f"seed clip {clip['clip']} ({clip['type']}); the model's speed after the seed v_cur = {v0:.2f} m/s")

fig, ax = plt.subplots(3, 1, figsize=(9, 5.5), sharex=True)
for k in np.flatnonzero(plan.types.max(0) > 0):
    ax[0].plot(plan.types[:, k], label=MOTION_TYPES[k])
ax[0].set_ylabel("type label"); ax[0].legend(loc="center right")
ax[1].plot(plan.speed); ax[1].set_ylabel("v_u (m/s)")
ax[2].plot(plan.turn); ax[2].set_ylabel("turn (+1 left)"); ax[2].set_xlabel("generated frame (60 fps)")
plt.tight_layout(); plt.show()

# %% [markdown]
# ## 2 · The session: CCNet one frame at a time under those controls

# %%
session.run(plan)
path, heading = session.root_path(*start)
free = new_session()
free.run(plan_controls([], n_frames, seed["type_index"], model.cfg.n_types))
free_path, _ = free.root_path(*start)

s = session.n_seed - 1
fig, ax = plt.subplots(figsize=(7, 7))
ax.plot(free_path[s:, 0], free_path[s:, 2], color="0.6", label="no keys (own c^d)")
ax.plot(path[:s + 1, 0], path[:s + 1, 2], color="k", lw=3, label="seed")
segments = [(0, 60, "walk"), (60, 180, "left"), (180, 300, "up x2"), (300, 400, "2: jog"), (400, 520, "right"),
            (520, n_frames, "on")]
for a, b, name in segments:
    ax.plot(path[s + a:s + b + 1, 0], path[s + a:s + b + 1, 2], lw=2, label=name)
for t in range(0, n_frames, 60):   # the fed c^d (green dots), every second
    pts = from_heading_frame_xz(session.controls[t].reshape(6, 2), heading[s + t]) + path[s + t, [0, 2]]
    ax.scatter(pts[:, 0], pts[:, 1], s=6, color="tab:green")
ax.set_aspect("equal"); ax.invert_yaxis()   # seen from above (Y up): +Z points down the page
ax.set_xlabel("X (m)"); ax.set_ylabel("Z (m)"); ax.legend(fontsize=8)
ax.set_title("root path under the scripted keys (green: the fed c^d)")
fig.savefig(fig_dir / "05_scripted_control_path.png", dpi=110); plt.show()

# %% [markdown]
# What each key did to the generated root path: the change of travel direction over a
# segment (+ = left) and the mean ground speed of its second half.

# %%
xz = path[s:, [0, 2]]


def direction(a, b):
    d = xz[b] - xz[a]
    return np.arctan2(d[0], d[1])


for a, b, name in segments[:-1]:
    turn = np.angle(np.exp(1j * (direction(b - 20, b) - direction(a, a + 20))))
    speed = np.linalg.norm(np.diff(xz[(a + b) // 2:b], axis=0), axis=1).mean() * 60
    asked = "own" if np.isnan(plan.speed[b - 1]) else f"requested {plan.speed[b - 1]:.2f}"
    print(f"{name:8s} frames {a:3d}-{b:3d}: turn {np.degrees(turn):+6.1f} deg, speed {speed:.2f} m/s ({asked})")
session_motion = features_to_motion(session.x(), ds.skeleton(row), *start)
write_bvh(session_motion, fig_dir / "05_scripted_control.bvh")
print("session exported to", fig_dir / "05_scripted_control.bvh")

# %% [markdown]
# ## 3 · A still of the session

# %%
sc = scene.ClipScene(session_motion, label="scripted keys, last frame")
scene.show(sc.frame(len(session_motion.root_positions) - 1), fig_dir / "05_scripted_control_last.png")

# %% [markdown]
# ## 4 · Live control (JupyterLab; full mode)
#
# Buttons for the number keys, up/down, left/right, a play toggle and *export BVH*; the view
# shows the character, its track and the six c^d points as green dots (Fig. 8). It needs a
# browser, so quick mode and CI skip it.

# %%
if not QUICK:
    from mocapviz.viz.live_control import LiveControl
    live = LiveControl(new_session(), ds.skeleton(row), *start, type_index=seed["type_index"])
    live.show(str(fig_dir / "05_live_session.bvh"))

# %% [markdown]
# ## 5 · Against the paper
#
# The paper shows interactive control in its video (1 m 32 s - 1 m 51 s) and Fig. 8, without
# numbers. What we check instead (`tests/test_control.py`, on the recommended generator and on
# `ccnet_default`, the paper's network at a CPU size): over five locomotion test seeds, holding
# left for 2 s turns the generated path further left than holding right, three "up" presses make
# it faster by more than 0.5 m/s, and a type key blends the label as the paper says. The paper's
# next-frame network `ccnet_paper` takes the same keys (the c^d it is fed bend and speed up as
# asked) but its character does not follow them: the test holds that as a strict expected
# failure. The numbers printed in section 3 are one seed's; control cannot be better than the
# model that follows the c^d. `tests/test_live_control.py` drives the widget of section 4 without
# a browser: its buttons turn the character, switch its type, and its export reads back.
