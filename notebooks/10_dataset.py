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
QUICK = True  # quick: 3 subjects (cmu07, cmu09, bd), 2 clips per motion type; full: every subject and clip
FIG_DIR = "../figures"

# %% [markdown]
# # 10 · A dataset of 4D body-motion cycles (multi-frame 4D motion paper §3.1, §4.1, §4.2)
#
# The paper learns one latent vector per **gait cycle of a dense body mesh sequence**. A cycle
# $S = [f_1, \dots, f_n]$ is stored compactly with a body model: one shape vector $\beta$ and
# $\chi = [\Theta, \Gamma, \Phi]$ — per-frame joint rotations, root translations and
# timestamps. The paper fits SMPL to AMASS and keeps 13 121 cycles found by dynamic time warping
# (DTW) of hip rotations against two hand-made reference cycles.
#
# We cannot use SMPL or AMASS. Instead we build the same kind of data from **real mocap** on
# **anny** (Apache-2.0 code, CC0 MakeHuman assets), a parametric body whose `cmu_mb` rig has the
# CMU skeleton's bone names:
#
# 1. $\beta$ = anny's 6 phenotype parameters (gender, age, muscle, weight, height, proportions),
#    fitted per subject to the mocap skeleton's segment lengths;
# 2. each clip retargeted onto its subject's anny body (anny rests in an A-pose, the mocap in
#    T-like poses: a per-joint rest alignment $Q_j$, then $G^{anny}_j = G^{src}_j Q_j$);
# 3. single cycles found by DTW of the hip flexion curves against a left-start reference cycle of
#    a real CMU walk (07_01, frames 134–261) and its mirror, threshold 10°, pruned to 0.3–3 s;
# 4. each cycle resampled to **100 frames**: $\Theta$ in the 6-D rotation form minus the identity
#    $[1,0,0,0,1,0]$, $\Gamma$ with the first frame at 0 scaled to $[-1, 1]$ per axis, $\Phi$ the
#    time since the start divided by 3 s, the initial root heading turned to face $+Z$.
#
# Everything below calls the library (`mocapviz.bodies`, `mocapviz.features.cycles`,
# `data_prep.body4d_dataset`, `mocapviz.viz`).

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep.body4d_dataset import (REFERENCE_CLIP, REFERENCE_FRAMES, Body4DConfig, build_dataset,
                                      reference_cycles, summary)
from data_prep.catalog import build_catalog, load_motion
from mocapviz.bodies import BETA_LABELS, body_model
from mocapviz.bodies.retarget import retarget, retarget_report
from mocapviz.features.cycles import hip_flexion, segment_cycles
from mocapviz.viz import (cycle_strips, plot_counts, plot_durations, plot_segmentation, retarget_overlay,
                          save_figure, set_notebook_backend, shape_lineup, show, subject_colors)

torch.set_num_threads(2)
set_notebook_backend(QUICK)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 160)

# %% [markdown]
# ## The body model and the dataset build
#
# `body_model()` creates anny's cmu_mb model once per process (float32, CPU). On a new machine
# the first creation builds anny's cache (~0.8 GB in `~/.cache/anny`, 1–3 min) and says so.
# `build_dataset` runs the whole pipeline and caches the result under `cache/body4d/`
# (`python -m data_prep build body4d` does the same from a shell; add `--quick` for the subset).

# %%
body = body_model()
config = Body4DConfig.quick() if QUICK else Body4DConfig()
ds = build_dataset(config)
print(summary(ds))
print(f"anny: {body.n_vertices} vertices, {body.n_joints} bones; chi per frame = {ds.chi.shape[-1]} numbers "
      f"({ds.meta['chi_layout']}); beta = {BETA_LABELS}")

# %% [markdown]
# ## Fitted shapes of every subject
#
# The fit minimises the squared error between anny's rest segment lengths (thighs, shins,
# feet, upper arms, forearms, hip width, shoulder width, trunk) and the subject's, with Adam on
# sigmoid-bounded phenotypes (adult ages only). "Before" is the neutral adult anny starts from.

# %%
subjects = ds.subjects.set_index("subject")
display(subjects[["source", "split", "err_before_cm", "err_after_cm", "max_after_cm", "height_m", *BETA_LABELS]].round(3))
colors = subject_colors(subjects.index, subjects["source"])
betas = {s: subjects.loc[s, list(BETA_LABELS)].values.astype(np.float32) for s in subjects.index}
p = shape_lineup(body, betas, colors, heights=subjects["height_m"].to_dict(),
                 title="anny bodies fitted to each subject's bone lengths (rest A-pose)")
show(p, fig_dir / "body4d_fig_shapes.png")

# %% [markdown]
# ## Retargeting check
#
# The source skeleton (red) drawn inside the retargeted anny mesh at a few frames. The numbers:
# mean distance between corresponding joints (hips, knees, ankles, balls of the feet, shoulders,
# elbows, wrists) over every frame, and the foot sliding (ground-plane speed of a foot's slowest
# joint, ankle or ball, while the source says it is in contact: `mocapviz.metrics.foot_sliding`)
# for the source and for anny.

# %%
display(ds.clips.groupby("type")[["joint_err_cm", "joint_err_max_cm", "slide_source_cm_s", "slide_anny_cm_s"]]
        .mean().round(2))
cat = build_catalog()
row = cat[cat["clip"] == REFERENCE_CLIP].iloc[0]
src = load_motion(row)
anny_motion = retarget(src, body.rest_skeleton(betas[row["subject"]]))
print(retarget_report(src, anny_motion))
p = retarget_overlay(body, betas[row["subject"]], src, anny_motion, frames=[0, 80, 160, 240])
show(p, fig_dir / "body4d_fig_retarget.png")

# %% [markdown]
# ## Gait-cycle segmentation (§4.1)
#
# Hip flexion of each thigh in the pelvis frame; every segment of a clip is compared by DTW
# (`dtaidistance`) to the left-start reference (grey: CMU 07_01 frames 134–261, from one left
# toe-off to the next) and to its mirror image; the best segments under the threshold are kept
# without overlap. Blue: left-start cycles, red: right-start; the number is the DTW distance.

# %%
refs = reference_cycles()
show_clips = [REFERENCE_CLIP] + [ds.cycles[ds.cycles.type == t]["clip"].iloc[0] for t in ("run", "jog", "sneak")
                                 if (ds.cycles.type == t).any()]
fig, axes = plt.subplots(len(show_clips), 1, figsize=(11, 2.4 * len(show_clips)), squeeze=False)
for ax, clip in zip(axes[:, 0], show_clips):
    m = load_motion(cat[cat["clip"] == clip].iloc[0])
    plot_segmentation(ax, hip_flexion(m), m.fps, segment_cycles(m, refs),
                      reference=REFERENCE_FRAMES if clip == REFERENCE_CLIP else None,
                      title=f"{clip} ({m.meta['motion_type']}, {m.meta['subject']})")
axes[0, 0].legend(fontsize=8, loc="lower right")
fig.tight_layout()
save_figure(fig, fig_dir / "body4d_fig_segmentation.png")

# %% [markdown]
# Two-legged hops (HDM05 `hopBothLegs1hops`) flex both hips **in phase**: no segment of them is
# close to an alternating gait cycle, so they give no cycles (distances 20–28° against the
# threshold of 10°). The paper's permissive threshold kept jogging and running, as ours does.

# %% [markdown]
# ## Dataset statistics

# %%
counts = ds.counts()
display(counts)
print("split:", ds.cycles.groupby("split").size().to_dict(), "— test subjects:", ds.meta["test_subjects"])
fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 3.6))
plot_counts(a1, counts, colors)
a1.set_title("cycles per motion type and subject")
plot_durations(a2, ds.cycles[~ds.cycles.mirrored])
a2.set_title("cycle durations")
fig.tight_layout()
save_figure(fig, fig_dir / "body4d_fig_stats.png")

# %% [markdown]
# ## Cycles as time-coloured frame strips (paper Fig. 6 style)
#
# Meshed on demand from $(\chi, \beta)$: 8 of the 100 frames of a cycle, dark to light in time,
# each where the body is (the cycle starts at the origin facing $+Z$), seen from the left.

# %%
picks = [int(ds.cycles.index[ds.cycles.type == t][0]) for t in ("walk", "run", "jog", "sneak")
         if (ds.cycles.type == t).any()]
labels = [f"{ds.cycles.type[i]} | {ds.cycles.subject[i]} | {ds.cycles.duration_s[i]:.2f} s" for i in picks]
cycle_strips(body, [ds.mesh(i).numpy() for i in picks], labels, path=fig_dir / "body4d_fig_cycles.png")
display(Image(filename=str(fig_dir / "body4d_fig_cycles.png")))

# %% [markdown]
# ## How this compares with the paper
#
# The paper's data is 13 121 AMASS cycles of hundreds of subjects; ours is a few dozen cycles of
# 16 real people (the shared CMU and HDM05 clips are short), enough to exercise every step of the
# method but far too few to train the CVAE at the paper's scale. The representation is the
# paper's with anny in place of SMPL: 21 joints instead of 20 (we drop joints that never move
# in the sources and the hands), $\beta \in \mathbb{R}^6$ instead of $\mathbb{R}^8$.
# Shape fits leave a few cm of segment-length error because the rigs define some joints
# differently (CMU's torso is short and its forearm ends at the marker-based wrist); the
# retargeted joints stay within ~3–7 cm of the source and the feet slide no more than in the
# source.
