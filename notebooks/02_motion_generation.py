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
QUICK = True     # quick: the quick dataset, 20 s generations, short low-fps renders; full: 60 s, mp4 too
FIG_DIR = "../figures"

# %% [markdown]
# # 02 · Motion generation: the recommended model, measured on poses (§4.2)
#
# Notebook `02_method` built CCNet's representation, network, loss and training. Here the
# network runs **free**: from a short real seed, each predicted frame is fed back as the next
# input for many seconds. The paper claims long generation that does not freeze. This notebook
# generates with the recommended model (the `mocapviz generate` default), measures the result
# at the level of **poses** with `mocapviz.metrics`, and sets it beside the paper's network
# (`ccnet_paper`) on the same seeds. How the recommended model came about, model by model, is
# the appendix notebook `appendix_generation_history` (run on demand) and
# [docs/experiments.md](../docs/experiments.md).

# %%
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep import zoo
from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from mocapviz import metrics
from mocapviz.features.motion_types import one_hot
from mocapviz.features.phase import LEFT_FOOT, RIGHT_FOOT, local_phase, phase_signal
from mocapviz.ik import foot_joints
from mocapviz.tasks.generate import Generator
from mocapviz.tasks.generation_defaults import GENERATION_MODEL, PACE, SAMPLING_TEMPERATURE, Z_SEARCH, Z_SOURCE
from mocapviz.tasks.generation_quality import (QUALITY_KEYS, SEED_FRAMES, TypeBanks, generation_quality,
                                               locomotion_seeds, moves_like_real, pose_distance, real_pose_distance,
                                               real_reference)
from mocapviz.viz import scene, show_figure
from mocapviz.zoo import MODELS, RECIPES

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
print("pyvista backend:", scene.set_notebook_backend(QUICK))
PAPER = pd.read_csv("../results/paper_ccnet_setup.csv").set_index("quantity")  # the paper's own numbers


def paper(quantity: str) -> str:
    """The paper's number for ``quantity`` (results/paper_ccnet_setup.csv), with its unit and section."""
    r = PAPER.loc[quantity]
    return f"{r.value:,g} {r.unit} ({r.section})"


PAPER_MODEL = "ccnet_paper"

# %% [markdown]
# ## 1 · The recommended model
#
# `ccnet_generate` is the paper's causal stack with additions that keep free-running motion
# alive; each is one field of its configuration, printed below against `ccnet_paper`:
#
# * **A phase** (`phase`, `phase_harmonics`): where the body is in its movement cycle, from the
#   clip's own main mode of pose change (`mocapviz.features.phase`), joins the control
#   $\mathbf c^d$, and the decoder's weights are a Fourier series in it (after PFNN). A network
#   that regresses the mean of the next frame averages the continuations it cannot tell apart;
#   once its own blurred output is its past, it no longer knows where in the gait cycle it is,
#   and the average of a cycle is a still pose. The phase keeps turning however blurred the pose.
# * **A latent $z$ blended between knots** (`latent`, `latent_hold`, `latent_lerp`): a conditional
#   VAE on the causal stack, one $z$ per knot a few frames apart, linearly blended between knots,
#   so that sampling bends the motion without a kick every frame.
# * **The plan and the root from the past alone** (`traj_without_z`, `root_without_z`): decoded
#   without $z$, so the mean output does not decode an average pace.
# * **Every body at many sizes** (training option `body_scale`): each window's body and motion
#   scaled by a random factor, so the network sees root height, pace and $\mathbf c^s$ change
#   together (most training frames come from one skeleton).
# * **A prior per motion type** (`mocapviz.models.type_prior`, fitted after training): each
#   type's mean and spread of $z$ and its usual phase pace, for a seed that shows no cycle.
#
# In generation, the `generate` command holds the speed of the plan the seed ended with
# (`pace`), takes $z$ from the seed's own frames (the posterior's mean over them, while the motion
# type is the seed's: `z_source`) and samples at a lowered temperature; the defaults are printed below.
# The `generate` command goes one step further for a user's file: it tries codes around the
# seed's $z$ and keeps the one whose 8 s run holds the seed's root height and lean best
# (`mocapviz.tasks.posture_search`, docs/your_own_file.md); the measurements here are the
# network's own output from the seed's $z$, without that search.

# %%
gen_model, gen_norm, gen_meta = zoo.load(GENERATION_MODEL)
paper_model, paper_norm, _ = zoo.load(PAPER_MODEL)
keys = ("channels", "skip_channels", "residual", "phase", "phase_harmonics", "latent", "latent_hold", "latent_lerp",
        "traj_without_z", "root_without_z")
print(pd.DataFrame({name: [getattr(m.cfg, k) for k in keys] for name, m in
                    ((GENERATION_MODEL, gen_model), (PAPER_MODEL, paper_model))}, index=list(keys)).to_string())
print(f"{GENERATION_MODEL}: trained with body_scale {MODELS[GENERATION_MODEL].body_scale} (config "
      f"{RECIPES[GENERATION_MODEL][0]!r}), type prior {'fitted' if getattr(gen_model, 'type_prior', None) is not None else 'missing'}; "
      f"generate defaults: pace {PACE!r}, z from {Z_SOURCE!r}, sampling temperature {SAMPLING_TEMPERATURE}; "
      f"the generate command also searches {Z_SEARCH} codes a round around the seed's z (not used below)")

# %% [markdown]
# ## 2 · Generation for three bodies
#
# Seeds: a second of a real clip of each body. Then autoregressive synthesis with the mean
# output, the clip's motion type and the network's own predicted trajectory control
# $\hat{\mathbf c}^d$ (the paper's fallback when the user gives none; following user paths is
# notebook 04), at the seed's pace: the held-out HDM05 subject (never seen in training) jogging,
# CMU subject 91 walking, and a held-out Bandai walk take. The poses come back through FK from
# the generated rotations, the path from the integrated root block, and foot sliding is cleaned
# by contact-triggered two-bone leg IK. Per body, the measures of `mocapviz.metrics`: the root's
# ground speed, foot sliding before and after the IK, the share of 1 s windows whose pose is
# frozen, and the distance of the poses to the nearest real pose of the type, as a ratio to
# the held-out real clips' own.

# %%
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
ds = ds.with_vocabulary(gen_model.cfg.n_types)
SECONDS = 20 if QUICK else 60
walk_take = ds.clips.iloc[locomotion_seeds(ds)[0]]["clip"]
subjects = {
    "tr (held out)": ds.clips[(ds.clips.subject == ds.meta["test_subject"]) & (ds.clips.type == "jog")]["clip"].iloc[0],
    "cmu91": "91_02",
    "bandai (held-out take)": walk_take,
}
banks = TypeBanks(ds)
generated, rows = {}, {}
for label, clip in subjects.items():
    row = ds.clip_row(clip)
    r, a = ds.clips.iloc[row], ds.clip_arrays(row)
    n = SECONDS * round(ds.config.fps)
    t = time.perf_counter()
    gen = Generator(gen_model, gen_norm, pace=PACE, z_source=Z_SOURCE)
    out = gen.run(a["x"][None, :SEED_FRAMES], a["skel"][None], one_hot([a["type_index"]], gen_model.cfg.n_types), n,
                  seed_traj=a["traj"][None, :SEED_FRAMES])
    dt = time.perf_counter() - t
    start, tag = (r.root_x, r.root_y, r.root_z), label.split()[0]
    raw = out.motion(0, ds.skeleton(row), start, r.heading, ik=False, name=f"ccnet_generated_{tag}")
    clean = out.motion(0, ds.skeleton(row), start, r.heading, ik=True, name=f"ccnet_generated_{tag}")
    generated[label] = dict(out=out, raw=raw, clean=clean, clip=clip)
    moving = raw[SEED_FRAMES:]
    feet = foot_joints(raw.skeleton)
    rows[label] = {
        "seed clip": clip, "type": r["type"], "frames per s": n / dt,
        "root speed (m/s)": metrics.root_speed(moving.root_positions, raw.fps),
        "foot slide raw (m/s)": metrics.foot_sliding(raw.positions(), raw.meta["contacts"], raw.fps, feet),
        "foot slide with IK (m/s)": metrics.foot_sliding(clean.positions(), raw.meta["contacts"], clean.fps, feet),
        "frozen 1 s windows": metrics.freezing_share(metrics.local_positions(moving.positions(), moving.skeleton), raw.fps),
        "pose distance / real": pose_distance(moving, banks[r["type"]])
        / real_pose_distance(ds, banks[r["type"]], r["type"]),
    }
print(pd.DataFrame(rows).T.to_string(float_format=lambda v: f"{v:.3f}"))
print(f"the paper's generation speed: {paper('generation_speed')}, its LibTorch demo")

# %% [markdown]
# Seconds 15-17 of each generation, rendered with pyvista as a film strip and an animation (quick
# mode: those 2 s at 6 frames/s; full mode: the whole generation at 30 frames/s, mp4 too):

# %%
for label, g in generated.items():
    name = g["clean"].name
    late = g["clean"][SEED_FRAMES + 15 * 60:SEED_FRAMES + 17 * 60]
    scene.frame_strip(late, fig_dir / f"{name}_strip.png", n=8)
    display(Image(filename=str(fig_dir / f"{name}_strip.png")))
    paths = [fig_dir / f"{name}.gif"] + ([] if QUICK else [fig_dir / f"{name}.mp4"])
    scene.render_clip(late if QUICK else g["clean"], paths, fps=6 if QUICK else 30, label=f"CCNet: {label}", progress=False)
    display(Image(filename=str(paths[0])))

# %% [markdown]
# ## 3 · The phase the generator feeds
#
# The phase is the Hilbert phase of the first principal component of the clip's root-relative
# joint positions (signed so that it moves the left foot forward), after a band-pass to the
# frequencies of human movement cycles; for a seed too short for that, one fitted sinusoid. In
# generation it starts as the seed's and turns on at the seed's own pace. A real walk's signal
# and phase (left), and the phase fed over the first seconds of the Bandai walk above (right):

# %%
walk_x = ds.clip_arrays(ds.clip_row(walk_take))["x"]
t_walk = np.arange(len(walk_x)) / ds.config.fps
fig, axes = plt.subplots(1, 2, figsize=(12, 3))
axes[0].plot(t_walk, phase_signal(walk_x, ds.layout), label="main component of the pose (m)")
axes[0].plot(t_walk, local_phase(walk_x, ds.layout) / np.pi, lw=0.8, label="phase / pi")
foot = walk_x[:, ds.layout.x_blocks["pos"]].reshape(len(walk_x), -1, 3)
axes[0].plot(t_walk, foot[:, LEFT_FOOT, 2] - foot[:, RIGHT_FOOT, 2], ls=":", label="left foot ahead of right (m)")
axes[0].set_xlabel(f"time (s), {walk_take}")
axes[0].legend(fontsize=7)
fed = generated["bandai (held-out take)"]["out"].phase[0][:5 * round(ds.config.fps)]
axes[1].plot(np.arange(len(fed)) / ds.config.fps, np.arctan2(fed[:, 0], fed[:, 1]) / np.pi)
axes[1].axvline(SEED_FRAMES / ds.config.fps, color="grey", lw=0.5)
axes[1].set_xlabel("time (s; seed before the grey line)")
axes[1].set_ylabel("phase fed / pi")
fig.tight_layout()
show_figure(fig)

# %% [markdown]
# ## 4 · Does it move, and like a person? Pose-level measures on ten seeds
#
# Autoregressive models often settle into a mean pose, or wander off the space of real poses.
# The measures read the **poses**: joint positions from FK, relative to the root joint and turned
# into the body's heading frame (`mocapviz.metrics.local_positions`), so a statue gliding along
# its path scores as frozen.
#
# Ten test seeds of locomotion and repeatable motion (`mocapviz.tasks.generation_quality.LOCOMOTION_SEEDS`)
# are generated free-running with the **mean** output and **sampled** (the `generate` command's
# pace and temperature), and the second half of each is measured (`mocapviz.tasks.generation_quality`,
# the same code as `python -m data_prep generation-table` and `benchmarks/bench_generation.py`):
#
# * freezing share (`metrics.freezing_share`): 1 s windows whose mean local joint speed is under
#   `metrics.FROZEN_SPEED` (no real clip has one);
# * activity (`metrics.activity`, pose change per second) and jitter (`metrics.jitter`, second
#   differences) as ratios to the real clips of the same type;
# * **pose distance** (`metrics.PoseBank`): each pose's distance to the nearest training pose of
#   its type, as a ratio to the held-out real clips of the type: a body tumbling through
#   impossible poses at a walk's pace has walk-like activity and jitter but not walk-like poses;
# * **root speed** (`metrics.root_speed`) as a ratio to the real clips' of the type: a walk that
#   glides along at several times a walker's pace is not a walk, whatever its legs do;
# * root height relative to the seed's (a drifting body shows there).
#
# `moves_like_real` combines them into one pass or fail per seed. Note what the data allow:
# HDM05's sneak and hop clips are single strides and hops and no source holds a minute of them;
# a model that stops after a sneak has learnt what it was shown.

# %%
secs = SECONDS
quality = {mode: generation_quality(gen_model, gen_norm, ds, secs, sample=mode == "sample", banks=banks, pace=PACE,
                                    temperature=SAMPLING_TEMPERATURE, z_source=Z_SOURCE)
           for mode in ("mean", "sample")}
for mode, q in quality.items():
    print(f"{GENERATION_MODEL}, {mode} output, {len(q['per_clip'])} x {secs} s, seconds {secs // 2}-{secs} "
          f"(min / median / max over the seeds):")
    for key, v in q["summary"].items():
        print(f"    {key:20s} {v}")
print(pd.concat({mode: pd.DataFrame(q["per_clip"]).T[["type", *QUALITY_KEYS]] for mode, q in quality.items()},
                axis=1).round(2).to_string())
for mode, q in quality.items():
    ok = [clip for clip, c in q["per_clip"].items() if moves_like_real(c)]
    print(f"{mode}: {len(ok)} of {len(q['per_clip'])} seeds move like the real clips: {', '.join(ok) or 'none'}")

# %% [markdown]
# The pose speed over time (`metrics.pose_speed`: mean local joint speed per frame) of two of
# these seeds, mean and sampled, against the mean of the real clips of the same type and the
# freezing threshold:

# %%
clips = list(quality["mean"]["per_clip"])[:2]
fig, axes = plt.subplots(1, 2, figsize=(12, 3.2), sharey=True)
for ax, clip in zip(axes, clips):
    for mode, q in quality.items():
        m = q["motions"][clip]
        speed = metrics.pose_speed(metrics.local_positions(m.positions(), m.skeleton), m.fps)
        ax.semilogy(np.arange(1, len(speed) + 1) / m.fps, np.maximum(speed, 1e-5), lw=0.7, label=f"generated, {mode}")
    ax.axhline(real_reference(ds, quality["mean"]["per_clip"][clip]["type"])[0], color="k", ls=":",
               label="real clips of this type")
    ax.axhline(metrics.FROZEN_SPEED, color="crimson", ls="--", label="freezing threshold")
    ax.axvline(SEED_FRAMES / ds.config.fps, color="grey", lw=0.5)
    ax.set_title(clip, fontsize=9)
    ax.set_xlabel("time (s; seed before the grey line)")
axes[0].set_ylabel("mean local joint speed (m/s)")
axes[0].legend(fontsize=7)
fig.tight_layout()
show_figure(fig)

# %% [markdown]
# ## 5 · Beside the paper's network
#
# `ccnet_paper` is the better next-frame predictor from the true past (the teacher-forced
# one-step table of `02_method`'s model, `results/ccnet_one_step.csv`), but free-running is a
# different task. The same ten seeds with its mean output, then the committed full-length
# tables of both models: the one-step error against repeating the last frame, and generation
# over the paper's length (`python -m data_prep generation-table`, the `command` column).

# %%
paper_quality = generation_quality(paper_model, paper_norm, ds, secs, sample=False, banks=banks)["per_clip"]
side = {f"{GENERATION_MODEL}, mean": quality["mean"]["per_clip"], f"{PAPER_MODEL}, mean": paper_quality}
print(pd.concat({k: pd.DataFrame(q).T[["freezing_share", "activity_ratio", "pose_distance_ratio", "root_speed_ratio"]]
                 for k, q in side.items()}, axis=1).astype(float).round(2).to_string())
for k, q in side.items():
    print(f"{k}: {sum(map(moves_like_real, q.values()))} of {len(q)} seeds move like the real clips, "
          f"{sum(c['freezing_share'] > 0 for c in q.values())} freeze at times")

# %%
models = [GENERATION_MODEL, PAPER_MODEL]
one_step = pd.read_csv("../results/ccnet_one_step.csv")
one_step = one_step[one_step.model.isin(models) & (one_step.split == "test")]
print("teacher-forced one-step error on the test clips (training std; results/ccnet_one_step.csv):")
print(one_step.pivot_table(index="block", columns="model", values=["mean_error", "copy_last"]).round(4).to_string())
committed = pd.read_csv("../results/ccnet_generation.csv")
committed = committed[committed.model.isin(models)]
print(f"\nfree-running generation of {committed.frames.max():,} frames per seed (the paper: more than "
      f"{paper('generated_frames')}), measured over the second half (results/ccnet_generation.csv):")
print(committed.groupby(["model", "mode"]).agg(
    seeds=("clip", "size"), move_like_real=("moves_like_real", "sum"), ever_frozen=("freezing_share", lambda s: int((s > 0).sum())),
    median_activity_ratio=("activity_ratio", "median"), median_pose_distance_ratio=("pose_distance_ratio", "median"),
    median_root_speed_ratio=("root_speed_ratio", "median")).round(2).to_string())
