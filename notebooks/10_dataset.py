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
QUICK = True  # quick: 7 subjects (CMU 07/09/35, HDM05 bd/tr, Bandai 1/2), 2 clips per type; full: every clip
FIG_DIR = "../figures"

# %% [markdown]
# # 10 · A dataset of 4D body-motion cycles (multi-frame 4D motion paper §3.1, §4.1, §4.2)
#
# The paper learns one latent vector per **gait cycle of a dense body mesh sequence**. A cycle
# $S = [f_1, \dots, f_n]$ is stored compactly with a body model: one shape vector $\beta$ and
# $\chi = [\Theta, \Gamma, \Phi]$ — per-frame joint rotations, root translations and
# timestamps. The paper fits SMPL to AMASS and keeps 13 121 cycles found by dynamic time warping
# (DTW) of the hip joints' rotations against hand-made reference cycles, pruned to 0.3–3 s.
#
# We cannot use SMPL or AMASS. Instead we build the same kind of data from **real mocap**
# (HDM05, CMU and Bandai Namco) on **anny** (Apache-2.0 code, CC0 MakeHuman assets), a
# parametric body whose `cmu_mb` rig has the CMU skeleton's bone names:
#
# 1. $\beta$ = anny's 6 phenotype parameters (gender, age, muscle, weight, height, proportions),
#    fitted per subject to the mocap skeleton's segment lengths under a **shape prior**: gender is
#    held at its recorded value (HDM05's five actors are men) or at 0.5 when unrecorded, age is
#    pulled to the neutral adult;
# 2. each clip retargeted onto its subject's anny body (Bandai first re-based onto a T-pose rest
#    like CMU's and HDM05's);
# 3. single cycles found by DTW of **four hip curves** (flexion and abduction of each thigh)
#    against real reference cycles of **forward walking** (CMU 07_01) and **backward walking**
#    (Bandai walk-back), each with its mirror image; candidates run from one maximal extension
#    of the leading thigh to a later one, **0.3–3 s** apart; cut-off, misshapen and half cycles
#    are rejected by a stated rule and listed;
# 4. each cycle resampled to **100 frames**: $\Theta$ in the 6-D rotation form minus the identity,
#    $\Gamma$ with the first frame at 0 scaled per axis by the **training cycles'** largest
#    $|\Gamma|$, $\Phi$ the time since the start divided by 3 s, the first heading facing $+Z$.
#
# Everything below calls the library (`mocapviz.bodies`, `mocapviz.features.cycles`,
# `data_prep.body4d_dataset`, `data_prep.body4d_splits`, `mocapviz.viz`).

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep.body4d_dataset import (REFERENCES, Body4DConfig, build_dataset, load_clip, reference_cycles,
                                      summary)
from data_prep.body4d_splits import SUBJECT_GENDER
from data_prep.catalog import build_catalog
from data_prep.sources import SOURCES, find_data_dir
from mocapviz.bodies import BETA_LABELS, body_model
from mocapviz.bodies.retarget import retarget, retarget_report
from mocapviz.features.cycles import EDGE_S, HALF_CYCLE_TRAVEL, MIN_CORRELATION, find_cycles, hip_flexion
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
# ## Fitted shapes of every subject, and the shape prior
#
# The fit minimises the squared error between anny's rest segment lengths (thighs, shins, feet,
# upper arms, forearms, hip width, shoulder width, trunk) and the subject's, with Adam on
# sigmoid-bounded phenotypes. Bone lengths cannot tell a man from a woman: fitted freely, gender
# ran to a bound and every body came out female, although HDM05's five actors are men. So gender
# is **never fitted**: HDM05's actors are held male (`gender_recorded`); CMU's subset and Bandai
# record no gender, so those bodies stay at anny's midpoint 0.5 — neither look, and said so.
# Bandai's three actors share one proportion-aligned skeleton (its bone lengths carry no
# identity), so Bandai gives one body. Age, nearly as unidentifiable, sat at a bound of its
# adult window for every subject; a quadratic pull towards the neutral adult (0.8, ~41 y) keeps
# it inside at a cost of under 0.1 cm of segment error. "Before" is the neutral adult.

# %%
subjects = ds.subjects.set_index("subject")
display(subjects[["source", "split", "gender_recorded", "err_before_cm", "err_after_cm", "max_after_cm",
                  "height_m", *BETA_LABELS]].round(3))
print("recorded genders (0 = male):", SUBJECT_GENDER)
colors = subject_colors(subjects.index, subjects["source"])
betas = {s: subjects.loc[s, list(BETA_LABELS)].values.astype(np.float32) for s in subjects.index}
p = shape_lineup(body, betas, colors, heights=subjects["height_m"].to_dict(),
                 title="anny bodies fitted to each subject's bone lengths (rest A-pose; HDM05 held male)")
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
display(ds.clips.groupby(["source", "type"])[["joint_err_cm", "joint_err_max_cm", "slide_source_cm_s",
                                              "slide_anny_cm_s"]].mean().round(2))
root = find_data_dir()
cat = build_catalog(root, sources=SOURCES)
ref_clip = REFERENCES["walk"][0]
row = cat[cat["clip"] == ref_clip].iloc[0]
src = load_clip(row, root)
anny_motion = retarget(src, body.rest_skeleton(betas[row["subject"]]))
print(retarget_report(src, anny_motion))
p = retarget_overlay(body, betas[row["subject"]], src, anny_motion, frames=[0, 80, 160, 240])
show(p, fig_dir / "body4d_fig_retarget.png")

# %% [markdown]
# ## Are Bandai's "walk-left/right" side steps?
#
# Bandai's README calls its `walk-left`/`walk-right` takes side steps. A side step travels at
# about ±90° from where the pelvis faces, a backward walk at 180°, a forward walk at 0°. Median
# angle from the pelvis heading to the direction of travel, per clip (`heading_offset`):

# %%
display(ds.clips.groupby(["source", "type"])["heading_offset_deg"].describe()[["count", "50%", "min", "max"]]
        .round(1))
side = cat[cat["motion_type"].str.startswith("side-step")]["clip"]
print("Bandai walk-left/right in this build:", ds.clips["clip"].isin(side).sum(), "clips, heading offsets",
      ds.clips.loc[ds.clips["clip"].isin(side), "heading_offset_deg"].round(0).tolist())

# %% [markdown]
# They are forward walks towards the left or right (offsets within ~25° of 0, not 90°), so the
# dataset types them `walk`. The shared data holds no side-step clip, so there is no side-step
# reference; the abduction curves and the reference list (`REFERENCES`) are ready for one.

# %% [markdown]
# ## Gait-cycle segmentation (§4.1)
#
# Hip flexion of each thigh in the pelvis frame (abduction is compared too, not drawn). A
# left-start cycle runs from one maximal extension of the left thigh (a flexion minimum, at
# toe-off) to a later one 0.3–3 s on; each candidate is compared by DTW with the references of
# its side, and the best under the threshold are kept without overlap. Blue: left-start,
# red: right-start; the number is the DTW distance. The references:

# %%
refs = reference_cycles(root)
for r in refs:
    print(f"{r.kind:10s} {r.source}: {(len(r.left) - 1) / r.fps:.2f} s")
fig, axes = plt.subplots(1, len(refs), figsize=(11, 2.6), squeeze=False)
for ax, r in zip(axes[0], refs):
    t = np.arange(len(r.left)) / r.fps
    for k, name in enumerate(["flexion L", "flexion R", "abduction L", "abduction R"]):
        ax.plot(t, r.left[:, k], label=name, ls="-" if k < 2 else ":")
    ax.set_title(f"{r.kind}: {r.source}", fontsize=9)
    ax.set_xlabel("time (s)")
axes[0, 0].set_ylabel("degrees")
axes[0, 0].legend(fontsize=7)
fig.tight_layout()
save_figure(fig, fig_dir / "body4d_fig_references.png")

# %%
show_types = ["walk", "run", "jog", "walk_back", "turn_left"]
show_clips = [ref_clip] + [ds.cycles[ds.cycles.type == t]["clip"].iloc[-1] for t in show_types
                           if (ds.cycles.type == t).any()]
fig, axes = plt.subplots(len(show_clips), 1, figsize=(11, 2.3 * len(show_clips)), squeeze=False)
for ax, clip in zip(axes[:, 0], show_clips):
    m = load_clip(cat[cat["clip"] == clip].iloc[0], root)
    kept, _ = find_cycles(m, refs, threshold=config.threshold)
    plot_segmentation(ax, hip_flexion(m), m.fps, kept,
                      reference=REFERENCES["walk"][1:] if clip == ref_clip else None,
                      title=f"{clip} ({m.meta['motion_type']}, {m.meta['subject']}): "
                            f"{', '.join(sorted({c.kind for c in kept}))}")
axes[0, 0].legend(fontsize=8, loc="lower right")
fig.tight_layout()
save_figure(fig, fig_dir / "body4d_fig_segmentation.png")

# %% [markdown]
# ## Rejected segments: the rule, and every one of them
#
# A segment that matched a reference under the DTW threshold is still rejected when
#
# - **edge**: it starts or ends within one 30-fps frame of the clip's first or last frame (a
#   cut-off clip; a cycle cut mid-way has no extension event at the cut and never becomes a
#   candidate);
# - **shape**: its four curves, uniformly resampled to the reference's length, correlate with the
#   reference's below the threshold printed below (DTW's warping can fold another movement onto
#   the reference at a small cost; a correlation without warping cannot);
# - **duration**: outside 0.3–3 s (cannot happen with the candidate window; the paper's rule);
# - **half**: it travels less than half the median travel of its subject's cycles of that type
#   (a step taken for a stride).
#
# HDM05's `sneak2StepsLStart` clips hold two steps: one stride at most, whose ends are the clip's
# ends, so they give no cycle now (the earlier "sneak cycles" of 0.29–0.36 m were half cycles).

# %%
print(f"edge {EDGE_S:.3f} s, correlation >= {MIN_CORRELATION}, half: travel < {HALF_CYCLE_TRAVEL} x median")
rej = ds.rejected
if len(rej):
    real_rej = rej[~rej["mirrored"]]
    display(ds.counts("reason", "type", table="rejected"))
    display(real_rej[["clip", "type", "kind", "side", "start", "end", "duration_s", "travel_m", "dtw_distance",
                      "correlation", "reason"]].round(2))
else:
    print("no segment of this build was rejected")

# %% [markdown]
# The rule on cut clips, in every mode: the reference walk cycle of 07_01 (frames 134–261) in a
# clip that starts 2 frames before it (rejected: edge), and the whole clip (kept).

# %%
m = load_clip(row, root)
fig, axes = plt.subplots(2, 1, figsize=(11, 4.4))
for ax, (part, label) in zip(axes, [(m[132:300], "07_01 from frame 132"), (m, "07_01, whole clip")]):
    kept, bad = find_cycles(part, refs, threshold=config.threshold)
    plot_segmentation(ax, hip_flexion(part), part.fps, kept, title=f"{label}: kept {len(kept)}")
    for c, why in bad:
        ax.axvspan(c.start / part.fps, c.end / part.fps, color="k", alpha=0.15)
        ax.text((c.start + c.end) / 2 / part.fps, 0, f"rejected: {why}", ha="center", fontsize=9)
fig.tight_layout()
save_figure(fig, fig_dir / "body4d_fig_rejected.png")

# %% [markdown]
# ## The split, the scales, and the counts by source and type
#
# The paper holds out whole AMASS sources; ours would leave one source's few cycles in test and
# take its bodies out of training. Instead every body trains but three: the real cycles of HDM05
# `tr`, CMU 35 (walk) and CMU 09 (run) are held out (`held_out_subjects`); Bandai's takes are
# spread over the training bodies (column `body`), and a share of them is held out on Bandai's
# body (`held_out_takes`) and on a held-out body (`held_out_bodies`); another share validates
# (`split == "val"`). See `data_prep/body4d_splits.py`. The column `test_set` says which test set a
# cycle belongs to; `mirrored` flags augmentation copies, which `ds.indices("test")` leaves out of
# every test metric. $\Gamma$'s scale is the **training** cycles' largest $|\Gamma|$ per axis;
# test cycles may exceed 1.

# %%
display(ds.counts(["source", "type"], "split"))
display(ds.counts("type", "test_set"))
n_theta = 6 * len(ds.meta["chi_joints"])
gam = np.abs(ds.chi[..., n_theta:n_theta + 3])
for split in ("train", "test"):
    idx = ds.indices(split)
    print(f"{split}: {len(idx)} cycles, max |Gamma| / scale per axis:",
          gam[idx].max(axis=(0, 1)).round(2) if len(idx) else "-")
print("gamma_scale (m):", np.round(ds.gamma_scale, 3), "from", ds.meta["gamma_scale_from"])
print(f"build: {ds.meta['build_seconds']} s for this config")

# %%
colors = subject_colors(subjects.index, subjects["source"])
fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 3.6))
plot_counts(a1, ds.counts(), colors)
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
picks = [int(ds.cycles.index[ds.cycles.type == t][0]) for t in ("walk", "run", "jog", "walk_back", "turn_left")
         if (ds.cycles.type == t).any()]
labels = [f"{ds.cycles.type[i]} | {ds.cycles.subject[i]} | {ds.cycles.duration_s[i]:.2f} s" for i in picks]
cycle_strips(body, [ds.mesh(i).numpy() for i in picks], labels, path=fig_dir / "body4d_fig_cycles.png")
display(Image(filename=str(fig_dir / "body4d_fig_cycles.png")))

# %% [markdown]
# ## How this compares with the paper
#
# The paper's data is 13 121 AMASS cycles of hundreds of subjects, its test sets whole AMASS
# sources. Ours is the count printed above (full build: every locomotion take of Bandai plus the
# CMU and HDM05 clips) of 16 mocap bodies and one Bandai body; the held-out subjects are HDM05 tr,
# CMU 35 and 09. The types the paper interpolates are in the training data:
# run and walk, walk-back and walk, left and right turns (Bandai). Side steps are not: the shared
# data has none. The representation is the paper's with anny in place of SMPL: 21 joints instead
# of 20 (we drop joints that never move in the sources, and the hands), $\beta \in \mathbb{R}^6$
# instead of $\mathbb{R}^8$. Shape fits leave a few cm of segment-length error because the rigs
# define some joints differently, and more for the men held male than a free fit would (which
# made them women to shorten segments).
