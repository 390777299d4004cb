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
QUICK = True  # quick: skeletons from one clip per subject, a short low-fps clip render
CLIP = "16_27"  # the clip rendered at the end: CMU subject 16 walking with a 90-degree turn
FIG_DIR = "../figures"

# %% [markdown]
# # 01 · The dataset (CCNet §4.1.1)
#
# CCNet learns one motion model for **many different bodies**: every frame is conditioned on
# the subject's skeleton configuration (root height and rest-pose joint positions), so the
# network has to see several skeletons doing the same kinds of motion. The paper recorded its
# own data: **12 subjects** (3 women), heights 1.54–1.95 m, **10 motion types** (walk, run,
# three kinds of jump, walk backward, zombie walk, kick, punch, kick+punch), about 20 minutes per
# subject, **486,282 frames** at 60 fps of **27 non-finger joints**; subject 7 is held out for
# testing (Fig. 3 shows the skeletons side by side).
#
# That dataset is not public. Here we use real, public motion capture with the same idea,
# several calibrated skeletons performing shared motion types:
#
# * **HDM05**: 5 actors (bd, bk, dg, mm, tr), 11 motion classes (squats, hops, kicks, jogging in a
#   circle, lying down, ...), ASF/AMC at 120 fps, each actor with their own skeleton;
# * **CMU** (BVH conversion by B. Hahne): 14 subjects, 15 short clips of walking, running,
#   jumping and kicking at 120 fps.
#
# Both share the 31-joint VICON tree; CCNet's 25 joints are that tree without hands and fingers.
# Together they hold about 10 minutes, some 70k frames at 120 fps (35k at CCNet's 60 fps): many
# bodies, few frames per body. The CCNet dataset adds
#
# * **Bandai Namco Research Motion Dataset** (BVH, 30 fps, CC BY-NC): 1,256 takes, about 110
#   minutes of walks, turning walks, runs, walking backwards, side steps, hand actions, gestures,
#   fighting and dance in 7-15 styles, on one proportion-aligned skeleton (no body variety).
#
# This notebook looks at the bodies (HDM05 and CMU); the last section shows the CCNet dataset
# built from all three (HDM05 + CMU + Bandai, about 120 minutes at 60 fps).

# %%
from pathlib import Path

import pandas as pd
from IPython.display import Image, display

from data_prep.catalog import build_catalog, load_motion, summary_table
from mocapviz.viz import plots, scene, show_figure, subject_colors

fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
print("pyvista backend:", scene.set_notebook_backend(QUICK))

# %% [markdown]
# ## Subjects, motion types and frames
#
# The catalog lists every clip found in the data folder (frame counts read from the files; the
# T-pose that Hahne's conversion inserts as frame 0 of each CMU file is not counted).

# %%
catalog = build_catalog()
catalog = catalog[catalog.source.isin(["hdm05", "cmu"])].reset_index(drop=True)
table = summary_table(catalog)
table.to_csv(fig_dir / "ccnet_dataset_summary.csv")
seconds = table.xs("seconds", level="quantity", axis=1).round(1)
seconds.style.format("{:.1f}").background_gradient(axis=None, cmap="Blues", subset=seconds.columns[:-1])

# %% [markdown]
# Totals next to the paper's (CCNet §4.1.1):

# %%
ours = {
    "subjects": catalog.subject.nunique(),
    "motion types": catalog.motion_type.nunique(),
    "frames": int(table[("total", "frames")].sum()),
    "frames at 60 fps": int((catalog.duration_s * 60 + 1).sum()),
    "minutes": round(catalog.duration_s.sum() / 60, 1),
    "joints (no fingers)": 25,
}
paper = {"subjects": 12, "motion types": 10, "frames": 486_282, "frames at 60 fps": 486_282,
         "minutes": round(486_282 / 60 / 60, 1), "joints (no fingers)": 27}
pd.DataFrame({"CCNet paper": paper, "ours (HDM05 + CMU)": ours})

# %%
colors = subject_colors(table.index.get_level_values("subject"), table.index.get_level_values("source"))
fig = plots.plot_dataset_minutes(catalog, table.index.get_level_values("subject"),
                                 fig_dir / "dataset_seconds_per_subject.png")
show_figure(fig)

# %% [markdown]
# HDM05 gives each actor minutes of varied motion; the CMU clips are seconds long (some are
# 0.35 s excerpts around a jump or a kick). So HDM05 carries the training signal, and CMU adds
# skeleton variety, the thing CCNet's conditioning is about.
#
# ## The skeletons (Fig. 3a)
#
# One skeleton per subject. In quick mode we read each subject's shortest clip (a skeleton is
# the same in all of a subject's files); in full mode we load every clip and check its frame
# count against the catalog.

# %%
subjects = list(table.index.get_level_values("subject"))
if QUICK:
    rows = catalog.loc[catalog.groupby("subject").frames.idxmin()]
else:
    rows = catalog
motions = {}
for _, row in rows.iterrows():
    m = load_motion(row)
    assert m.n_frames == row.frames, (row.clip, m.n_frames, row.frames)
    motions[row.clip] = m
skeletons = {s: next(m.skeleton for m in motions.values() if m.meta["subject"] == s) for s in subjects}
print(f"loaded {len(motions)} clips, {sum(m.n_frames for m in motions.values())} frames")

# %% [markdown]
# The pose: each skeleton's **rest pose** (all joint rotations identity, the pose CCNet's
# skeleton configuration $c^s$ is built from) with the thighs turned to hang straight down and
# the arms lowered, so the bodies stand on the floor like the paper's Fig. 3a and fit side by
# side. (HDM05 has no T-pose frame and a "neutral" frame from a clip would mix pose with
# skeleton.) The number above each body is `Skeleton.standing_height()`: trunk, neck and head
# bone lengths plus the straightened leg.

# %%
p = scene.skeleton_lineup(skeletons, colors)
scene.show(p, fig_dir / "ccnet_fig03a_skeletons.png")

# %% [markdown]
# ## Bone lengths across subjects

# %%
bones = plots.bone_length_table(skeletons)
fig = plots.plot_bone_lengths(bones, colors, fig_dir / "ccnet_bone_lengths.png")
show_figure(fig)

# %%
bones.describe().loc[["mean", "std", "min", "max"]].round(3)

# %% [markdown]
# The paper's subjects range from 1.54 to 1.95 m; our HDM05 actors from 1.68 to 1.84 m. The CMU
# subjects come out 1.37–1.58 m, shorter than the adults they are, and the heat map shows why:
# in Hahne's BVH conversion the **thorax** bone (Spine1 → Neck) and the thorax-to-clavicle offset
# have length 0, so every CMU trunk lacks 11–15 cm that HDM05's ASF skeletons keep. For CCNet this
# is simply another skeleton configuration, but heights of CMU subjects should not be read as
# their real heights.
#
# ## One clip: ground, root trajectory, frames
#
# A clip drawn on the ground plane with its root trajectory projected onto the floor (blue).

# %%
row = catalog[catalog["clip"] == CLIP].iloc[0]
clip = motions.get(CLIP) or load_motion(row)
clip_fps = 15 if QUICK else 30
paths = scene.render_clip(clip, [fig_dir / f"dataset_clip_{CLIP}.gif", fig_dir / f"dataset_clip_{CLIP}.mp4"],
                          fps=clip_fps, color=colors[row.subject],
                          label=f"{CLIP} ({row.subject}, {row.motion_type}, {clip.duration:.1f} s)")
display(Image(filename=str(paths[0])))

# %%
scene.frame_strip(clip, fig_dir / f"dataset_clip_{CLIP}.png", n=6, color=colors[row.subject])
display(Image(filename=str(fig_dir / f"dataset_clip_{CLIP}.png")))

# %% [markdown]
# ## Representation (CCNet §3.1)
#
# CCNet models the next frame vector $\mathbf x_n$ given the past frames and a control
# $\mathbf c_n$. The dataset build (`python -m data_prep build ccnet`, cached in `cache/ccnet/`)
# keeps the 25 modelled joints, resamples every clip to CCNet's 60 fps and computes, per frame and
# in the previous frame's heading frame (Y up, on the ground under the previous root, facing where
# the body faced):
#
# * $\mathbf x^e$ exponential-map local rotations, $\mathbf x^\omega$ their angular velocities,
#   $\mathbf x^p$ joint positions relative to the previous root frame, $\mathbf x^v$ joint linear
#   velocities, $\mathbf x^f$ two foot-contact labels, and a 4-value root block (planar velocity,
#   heading rate, root height) that generation integrates into the path;
# * the control: $\mathbf c^s$ (root height + root-relative rest joints, the skeleton
#   configuration), $\mathbf c^d$ (the root 10, 20, ..., 60 frames ahead in the current heading
#   frame, 12 values) and a one-hot motion type over the merged types of HDM05, CMU and Bandai
#   (`data_prep/motion_types.py`: Bandai's turning walks are walks, its runs join CMU's in *jog*).
#
# Bandai's 30 fps takes are resampled to 60 fps; its rig rest pose is re-based onto the VICON
# T-pose of HDM05 and CMU and the four joints it lacks (hip stubs, LowerBack, Neck1) are filled
# in with identity rotations, so that every block means the same thing for every source.
#
# The layout of $\mathbf x_n$ (one row per block, with its columns and unit):

# %%
from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from mocapviz.viz.ccnet import plot_controls

# quick mode: HDM05 + CMU + 3 Bandai takes of each content (seconds to build); full: every take
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
display(pd.DataFrame(ds.layout.table(), columns=["block", "start", "stop", "unit"]))
print(f"{ds.layout.n_x} values a frame; "
      f"{len(ds.clips)} clips, {len(ds.x)} frames at {ds.config.fps:g} fps; "
      f"held-out subject {ds.meta['test_subject']!r}")

# %% [markdown]
# The dataset by source and motion type: frames at 60 fps and minutes in the training,
# validation and test splits. Test holds the HDM05 actor *tr*, one clip of every other subject
# with two long-enough clips, and a seeded 10 % of Bandai's takes per content; validation the
# HDM05 actor *mm* and another 10 % of Bandai's takes. Windows are 120 frames (2 s): shorter
# clips stay in the table but give no training windows. (Quick mode shows the quick subset;
# the full table is in the README.)

# %%
table = ds.table()
table.to_csv(fig_dir / "ccnet_dataset_table.csv")
table

# %% [markdown]
# The controls drawn over a real clip, HDM05 actor *bd* jogging in a left circle. Left: the root
# path from above and, every 20 frames, the six points of $\mathbf c^d$ (where the root will be
# over the next second). Right: the foot-contact labels and the root block over time.

# %%
row = ds.clip_row("HDM_bd_jogLeftCircle4StepsRstart_001_120")
r, arrays = ds.clips.iloc[row], ds.clip_arrays(row)
fig = plot_controls(arrays["x"], arrays["traj"], (r.root_x, r.root_y, r.root_z), r.heading,
                    title=f"{r['clip']} (type {r['type']})", path=fig_dir / "ccnet_representation_controls.png")
show_figure(fig)
