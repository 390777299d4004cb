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
QUICK = True     # quick: committed checkpoint, a 60-step demo run, short low-fps renders
RETRAIN = False  # True: train the default config from scratch instead of loading the committed one
FIG_DIR = "../figures"

# %% [markdown]
# # 02 · CCNet: representation, architecture, training and generation (§3, §4.2)
#
# CCNet models human motion **one frame at a time**: given the previous frames
# $\mathbf X = \{\mathbf x_{n-l-1},\dots,\mathbf x_{n-1}\}$ and the control signal $\mathbf c_n$ of the
# frame to predict, the network outputs a diagonal Gaussian over the next frame,
# $p(\mathbf x_n\mid\mathbf X,\mathbf c_n)=F_\theta(\mathbf X,\mathbf c_n)$ (Eq. 1). Because the
# control includes the **skeleton configuration** of the subject, one network models the motion
# of many different bodies. Generation feeds each predicted mean back as the next input.
#
# This notebook walks through our implementation on the real HDM05 + CMU + Bandai data of
# notebook 01 (dataset v4): the frame vector and the controls, the network (Eq. 2-5), the loss
# (Eq. 6-10), training (§4.2), and long generated motion for three bodies, one of them the
# held-out test subject, measured at the level of poses.

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
from mocapviz.features.motion_types import one_hot
from mocapviz.ik import foot_joints
from mocapviz import metrics
from mocapviz.metrics import foot_sliding
from mocapviz.models.ccnet_config import receptive_field
from mocapviz.models.protocol import count_parameters
from mocapviz.tasks.generate import Generator
from mocapviz.tasks.generation_defaults import GENERATION_MODEL, SAMPLING_TEMPERATURE
from mocapviz.tasks.generation_quality import (
    QUALITY_KEYS,
    SEED_FRAMES,
    TypeBanks,
    generation_quality,
    locomotion_seeds,
    moves_like_real,
    pose_distance,
    real_pose_distance,
    real_reference,
    within_issue_bar,
)
from mocapviz.tasks.one_step import linear_code_residual, one_step_table, root_bias_table
from mocapviz.training.config import TRAIN_CONFIGS
from mocapviz.training.trainer import evaluate
from mocapviz.training.windows import WindowData
from mocapviz.viz import scene, show_figure
from mocapviz.viz.ccnet import plot_controls, plot_training_curves

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
print("pyvista backend:", scene.set_notebook_backend(QUICK))

# %% [markdown]
# ## 1 · The frame vector $\mathbf x_n$ and the control $\mathbf c_n$ (§3.1)
#
# The dataset build (`python -m data_prep build ccnet`, cached under `cache/ccnet/`) keeps
# CCNet's 25 joints, resamples every clip to 60 fps and computes, per frame, in the **previous
# frame's heading frame** (a Y-up frame on the ground under the previous root, turned to the
# direction the body faced):
#
# * $\mathbf x^e$ exponential-map local joint rotations (the root's relative to its heading),
#   $\mathbf x^\omega$ their angular velocities, $\mathbf x^p$ joint positions relative to the
#   previous root frame, $\mathbf x^v$ joint linear velocities, $\mathbf x^f$ two foot contacts;
# * a 4-value **root** block (planar velocity, heading rate, root height): what generation
#   integrates into the path.
#
# The control is $\mathbf c^s$ (root height + root-relative rest joint positions), the 12-D
# trajectory $\mathbf c^d$ (the root 10, 20, ..., 60 frames ahead, in the current heading frame),
# and a one-hot motion type over our merged types (HDM05's 11 classes with CMU's walk/run/jump/
# kick mapped in, then Bandai's contents appended: dash, walk-back, side step, wave, raise hand,
# gesture, slash, dance; Bandai's run counts as jog and its turning walks as walk).

# %%
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
layout = ds.layout
display(pd.DataFrame(layout.table(), columns=["block", "start", "stop", "unit"]))
m = ds.meta
print(f"{len(ds.clips)} clips, {m['n_frames']} frames at 60 fps ({m['n_frames'] / 3600:.1f} min), "
      f"{m['n_train_frames']} for training; test: subject {m['test_subject']!r} (all clips) + one clip of "
      f"every other HDM05 subject + a seeded share of Bandai takes = {len(m['test_clips'])} clips; validation "
      f"(model selection): the held-out actor {m['val_subject']!r} + a share of Bandai takes = "
      f"{len(m['val_clips'])} clips")
display(ds.clips.groupby(["split", "type"]).size().unstack(0).fillna(0).astype(int).T)

# %% [markdown]
# The controls over a clip: HDM05 actor *bd* jogging in a left circle. Left: the root path from
# above and, every 20 frames, where $\mathbf c^d$ says the root will be over the next second.
# Right: the contact labels and the root block over time.

# %%
row = ds.clip_row("HDM_bd_jogLeftCircle4StepsRstart_001_120")
r, a = ds.clips.iloc[row], ds.clip_arrays(row)
fig = plot_controls(a["x"], a["traj"], (r.root_x, r.root_y, r.root_z), r.heading,
                    title=f"{r['clip']} (type {r['type']})", path=fig_dir / "ccnet_representation_controls.png")
show_figure(fig)

# %% [markdown]
# ## 2 · The network (§3.2)
#
# * **Encoder** (Eq. 2): dropout 0.5 on the input frames, then Conv1D $k{=}1$ + ReLU.
# * **Separate residual blocks** (Fig. 2): a dilated *causal* Conv1D with kernel 2 (output $t$
#   sees inputs $t$ and $t-d_i$), plus each control type through **its own** Conv1D $k{=}1$,
#   summed in; WaveNet's gated unit $\tanh(\cdot)\odot\sigma(\cdot)$; a residual 1×1 back to the
#   block input and a skip 1×1 out.
# * **Skip sum** (Eq. 4) → **decoder** (Eq. 5): ReLU + Conv1D $k{=}1$ giving the mean, $s$ with
#   $\hat\sigma = e^{-s}$ clipped at $\geq 10^{-4}$, two foot-contact logits, and the predicted
#   trajectory control $\hat{\mathbf c}^d$ (mean and $\sigma$).
#
# The causal receptive field is $CRL=(k-1)+\sum_i d_i(k-1)$ (Eq. 3): 41 frames for 20 blocks with
# $d=2$. Note what the paper's choice implies: with every $d_i = 2$ the output at $t$ depends on
# inputs $t, t-2, \dots, t-40$ only: a *span* of 41 frames, 21 of them actually seen.

# %%
model, norm, meta = (None, None, None) if RETRAIN else zoo.load("ccnet_default")
if RETRAIN:
    model, norm, meta = zoo.load("ccnet_default", prefer_committed=False)
cfg = model.cfg
ds = ds.with_vocabulary(cfg.n_types)  # the clips of the types the model knows (older checkpoints: fewer)
print(f"default config: {len(cfg.dilations)} SRBs, dilations {set(cfg.dilations)}, C = {cfg.channels}, "
      f"skip = {cfg.skip_channels}: {count_parameters(model):,} parameters, CRL = {cfg.receptive_field}")
for d in [(2,) * 20, (1, 2) * 10, (1, 2, 4) * 6 + (1, 2)]:
    print(f"  dilations {d[:4]}...: CRL = {receptive_field(d)}")
ckpt = zoo.committed_path("ccnet_default")
if ckpt.is_file():
    print(f"committed checkpoint {ckpt.name}: {ckpt.stat().st_size / 2**20:.2f} MB, the best-by-validation "
          f"model of a {meta.get('final_step', meta['step'])}-step run: step {meta['step']}, validation NLL "
          f"{meta.get('val_nll')}, test NLL {meta.get('test_nll')}; command in models/README.md")

# %% [markdown]
# ## 3 · Loss and training (§3.3, §4.2)
#
# $L = L_G + 10\,L_s + 2\,L_f + 1\,L_d$: Gaussian NLL of the next frame (Eq. 7), smoothness of the
# predicted means (Eq. 8), foot-contact BCE (Eq. 9), and the Gaussian NLL of the predicted
# trajectory control (Eq. 10, folded in with weight 1). Eq. 8 as printed sums *signed* second
# differences, which can go negative; we penalise their **square, averaged over channels**
# (summed over 304 channels with weight 10 it made an early model output a constant mean). The
# channels that never vary in the training data (rotations of joints without rotational freedom)
# are left out of $L_G$ and $L_s$: kept in, their $\sigma$ shrank to ~0.002 and bought about
# −218 nats per frame for nothing. Whole windows at once (causality makes every output a valid
# next-frame prediction), i.i.d. N(0, 0.03²) noise on the normalised inputs.
#
# Optimiser: the `paper` config keeps RMSprop with lr 1e-4 → 1e-6. The `quick` and `default`
# configs start at 1e-3 (a CPU budget of a few thousand steps gets nowhere at 1e-4) and therefore
# use **Adam**: torch's RMSprop has no bias correction, and at 1e-3 it could not even overfit one
# training clip (`tests/test_ccnet_training.py`); the first committed model, trained that way,
# ignored its input and froze.

# %%
print(pd.DataFrame({k: {f: getattr(c, f) for f in ("size", "steps", "batch_size", "window", "lr", "lr_final",
                                                     "noise_std", "optimizer", "residual_blocks", "feedback_passes")}
                    for k, c in TRAIN_CONFIGS.items()}))
curves = {"default (committed)": Path("../models/zoo/ccnet_default_losses.csv")}
if QUICK:  # a short demonstration of the training loop itself (the curves above come from the real run)
    from dataclasses import replace

    from mocapviz.training.trainer import train
    demo = replace(TRAIN_CONFIGS["quick"], steps=60, eval_every=30, checkpoint_every=30)
    t = time.perf_counter()
    train(ds, demo, "../cache/runs/notebook_demo", resume=False)
    print(f"60 quick steps in {time.perf_counter() - t:.0f} s")
    curves["quick, 60-step demo"] = Path("../cache/runs/notebook_demo/losses.csv")
fig = plot_training_curves({k: v for k, v in curves.items() if v.is_file()}, path=fig_dir / "ccnet_training_curves.png")
show_figure(fig)

# %% [markdown]
# Model selection uses the **validation** split only: the trainer evaluates the validation NLL
# (the held-out HDM05 actor *mm* plus a share of Bandai takes) on its schedule and keeps the
# model with the lowest as `best.safetensors`; that is the model `--export` commits. The test NLL
# (held-out subject *tr*, one clip of each other subject, a share of Bandai takes) is logged for
# reporting only. $L_G$ is in nats per frame over the varying normalised channels. The paper
# reports $L\approx-300$ on *its* test split. The table gives our NLL per held-out group:

# %%
data = WindowData(ds, min(60, ds.config.window), normaliser=norm)
held_out = ds.clips.subject.values[data.test[:, 0]] == ds.meta["test_subject"]
splits = {"validation": data.val, "test": data.test, f"test, subject {ds.meta['test_subject']}": data.test[held_out],
          "test, other subjects and Bandai takes": data.test[~held_out]}
print(pd.DataFrame({k: {"windows": len(p), **evaluate(model, data, p)} for k, p in splits.items()}).T.round(2))

# %% [markdown]
# ## 4 · Generation for three bodies (§4.2)
#
# Seeds: 48 frames of a real clip of each body. Then autoregressive synthesis (the mean of each
# predicted Gaussian, fed back) with the clip's motion type and the network's own predicted
# trajectory control $\hat{\mathbf c}^d$ (the paper's fallback when the user gives none;
# following user paths is notebook 04): the held-out HDM05 subject *tr* (1.75 m, never seen in
# training) jogging, CMU subject 91 (1.37 m, a training subject) walking, and a held-out Bandai
# walk take. The poses come back through FK from the generated rotations, the path from the
# integrated root block, and foot sliding is cleaned by contact-triggered two-bone leg IK. The
# printed numbers say, per body, whether its pose keeps moving and how far its poses are from
# real ones (section 5 explains both); the film strips show seconds 15-17.

# %% [markdown]
# The generation sections use **`ccnet_phase_lerp`** (the `phase_lerp` config: the default network
# plus a local motion phase in its control and a phase-functioned decoder, section 5d, and a latent
# $z$ blended between knots 10 frames apart, section 5e; `models/README.md`), the committed model
# whose validation seeds move best, with the mean output and sampled; section 5 also prints the
# results of `ccnet_default`, `ccnet_wide` (C = 96, trained on its own predictions) and
# `ccnet_phase` (a new $z$ every frame) beside it.

# %%
gen_model, gen_norm, _ = zoo.load("ccnet_phase_lerp", retrain_if_missing=False)
phase_model, phase_norm, _ = zoo.load("ccnet_phase", retrain_if_missing=False)
wide_model, wide_norm, _ = zoo.load("ccnet_wide", retrain_if_missing=False)
SECONDS = 20
walk_take = ds.clips.iloc[locomotion_seeds(ds)[0]]["clip"]
subjects = {
    "tr (held out)": ds.clips[(ds.clips.subject == ds.meta["test_subject"]) & (ds.clips.type == "jog")]["clip"].iloc[0],
    "cmu91": "91_02",
    "bandai (held-out take)": walk_take,
}
banks = TypeBanks(ds)
generated = {}
for label, clip in subjects.items():
    row = ds.clip_row(clip)
    r, a = ds.clips.iloc[row], ds.clip_arrays(row)
    seed, n = SEED_FRAMES, SECONDS * 60
    t = time.perf_counter()
    out = Generator(gen_model, gen_norm).run(a["x"][None, :seed], a["skel"][None], one_hot([a["type_index"]], cfg.n_types), n,
                                     seed_traj=a["traj"][None, :seed])
    dt = time.perf_counter() - t
    start = (r.root_x, r.root_y, r.root_z)
    tag = label.split()[0]
    raw = out.motion(0, ds.skeleton(row), start, r.heading, ik=False, name=f"ccnet_generated_{tag}")
    clean = out.motion(0, ds.skeleton(row), start, r.heading, ik=True, name=f"ccnet_generated_{tag}")
    generated[label] = dict(out=out, raw=raw, clean=clean, clip=clip)
    speed = np.linalg.norm(np.diff(raw.root_positions[seed:, [0, 2]], axis=0), axis=1).mean() * 60
    slide = lambda m: foot_sliding(m.positions(), raw.meta["contacts"], m.fps, foot_joints(m.skeleton))  # noqa: E731
    moving = raw[seed:]
    frozen = metrics.freezing_share(metrics.local_positions(moving.positions(), moving.skeleton), raw.fps)
    print(f"{label:24s} seed {clip}: {n} frames in {dt:.2f} s; root speed {speed:.2f} m/s; foot slide "
          f"{slide(raw):.3f} -> {slide(clean):.3f} m/s with IK; pose frozen in {frozen:.0%} of its 1 s windows; "
          f"pose distance {pose_distance(moving, banks[r['type']]) / real_pose_distance(ds, banks[r['type']], r['type']):.1f}x the "
          f"held-out real {r['type']} clips'")

# %% [markdown]
# Rendered with pyvista (quick mode: 6 frames/s and a film strip; full mode: 30 frames/s mp4).

# %%
for label, g in generated.items():
    name = g["clean"].name
    late = g["clean"][SEED_FRAMES + 15 * 60:SEED_FRAMES + 17 * 60]
    scene.frame_strip(late, fig_dir / f"{name}_strip.png", n=8)
    display(Image(filename=str(fig_dir / f"{name}_strip.png")))
    paths = [fig_dir / f"{name}.gif"] + ([] if QUICK else [fig_dir / f"{name}.mp4"])
    scene.render_clip(g["clean"], paths, fps=6 if QUICK else 30, label=f"CCNet: {label}", progress=False)
    display(Image(filename=str(paths[0])))

# %% [markdown]
# ## 5 · Does it move, and like a person? Pose-level metrics
#
# Autoregressive models often settle into a mean pose, or wander off the space of real poses.
# The measures read the **poses**: joint positions from FK, relative to the root joint and turned
# into the body's heading frame (`mocapviz.metrics.local_positions`), so a statue gliding along
# its path scores as frozen. (An earlier version of this notebook read the network's velocity
# channels instead: they settle to a constant non-zero value while the pose is frozen.)
#
# Ten test seeds of locomotion and repeatable motion (walk, turning walk, run, jog, sneak, hop,
# walk-back, side step, waving, dash; `mocapviz.tasks.generation_quality.LOCOMOTION_SEEDS`) are
# generated free-running, with the **mean** output and with **sampling** from the predicted
# Gaussian, and the second half is measured (`mocapviz.tasks.generation_quality`, the same code as
# `benchmarks/bench_generation.py`, which runs 60 s):
#
# * freezing share: 1 s windows whose mean local joint speed is under 1 cm/s (no real clip has one);
# * activity (pose change per second) and jitter (second differences) as ratios to the real clips
#   of the same type;
# * **pose distance**: each pose's distance to the nearest training pose of its type (`metrics.PoseBank`), as a
#   ratio to the held-out real clips of the type: a body tumbling through impossible poses at a
#   walk's pace has walk-like activity and jitter but not walk-like poses;
# * **root speed**: the root's mean ground speed as a ratio to the real clips' of the type: a walk
#   that glides along at three times a walker's pace is not a walk, whatever its legs do
#   (`moves_like_real` also passes a speed within 0.1 m/s of the real one, for motion in place);
# * root height relative to the seed's (a drifting body shows there).
#
# Note what the data allow: HDM05's sneak and hop clips are single strides and hops (1-2 s) and
# no source holds a minute of them; a model that stops after a sneak has learnt what it was shown.

# %%
secs = 20 if QUICK else 60
quality = {mode: generation_quality(gen_model, gen_norm, ds, secs, sample=mode == "sample", banks=banks)
           for mode in ("mean", "sample")}
others = {("ccnet_default", "mean"): (model, norm), ("ccnet_wide", "mean"): (wide_model, wide_norm),
          ("ccnet_phase", "mean"): (phase_model, phase_norm), ("ccnet_phase", "sample"): (phase_model, phase_norm)}
other_quality = {}
for (name, mode), (m, nm) in others.items():
    other = other_quality[name, mode] = generation_quality(m, nm, ds, secs, sample=mode == "sample", banks=banks)["per_clip"]
    jitter = [c["jitter_ratio"] for c in other.values()]
    print(f"{name}, {mode} output: {sum(map(moves_like_real, other.values()))} of {len(other)} seeds move like the "
          f"real clips, {sum(c['freezing_share'] > 0 for c in other.values())} freeze at times, jitter "
          f"{min(jitter):.1f}-{max(jitter):.1f}x the real clips'; ccnet_phase_lerp below")
for mode, q in quality.items():
    print(f"{mode} output, {len(q['per_clip'])} x {secs} s, seconds {secs // 2}-{secs} (min / median / max over the seeds):")
    for key, v in q["summary"].items():
        print(f"    {key:20s} {v}")
print(pd.concat({mode: pd.DataFrame(q["per_clip"]).T[["type", *QUALITY_KEYS]] for mode, q in quality.items()},
                axis=1).round(2))
for mode, q in quality.items():
    ok = [clip for clip, c in q["per_clip"].items() if moves_like_real(c)]
    print(f"{mode}: {len(ok)} of {len(q['per_clip'])} seeds keep moving like the real clips (not frozen, activity "
          f"0.5-2x, jitter <= 3x, pose distance <= 3x, root speed 0.5-2x): {', '.join(ok) or 'none'}")

# %% [markdown]
# The pose speed over time (mean local joint speed per frame) of two of these seeds, mean and
# sampled, against the mean of the real clips of the same type and the freezing threshold:

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
    ax.axvline(SEED_FRAMES / 60, color="grey", lw=0.5)
    ax.set_title(clip, fontsize=9)
    ax.set_xlabel("time (s; seed before the grey line)")
axes[0].set_ylabel("mean local joint speed (m/s)")
axes[0].legend(fontsize=7)
fig.tight_layout()
show_figure(fig)

# %% [markdown]
# ## 5b · Why: the one-step prediction
#
# Before a network can run on its own output, it must predict the next frame from the *true*
# past better than doing nothing does. `mocapviz.tasks.one_step` feeds validation clips
# teacher-forced and compares, per block of the frame vector and in training standard
# deviations (the units the network reads), the median over frames and varying channels of the
# predicted $\sigma$, the error of the predicted mean, the error of repeating the last frame
# ("copy last"), and of constant-velocity extrapolation. Where the mean errs far more than
# copying does, the mean barely follows its input: fed back, it slides to a pose of its own and
# stays (freezing). Where $\sigma$ is far above a frame's real change, each sample jumps
# farther than real motion moves in a frame (noise).

# %%
val_rows = np.flatnonzero((ds.clips.split == "val").values)[:12]
compared = {"ccnet_default": (model, norm), "ccnet_wide": (wide_model, wide_norm), "ccnet_phase_lerp": (gen_model, gen_norm)}
one_step = {name: one_step_table(m, nm, ds, val_rows) for name, (m, nm) in compared.items()}
print(pd.concat(one_step, axis=1).round(4).to_string())
for name, t in one_step.items():
    r = t.loc["rot"]
    print(f"{name}: on the median rotation channel the mean errs by {r.mean_error:.2f} training std, "
          f"{r.mean_error / r.copy_last:.0f}x what repeating the last frame errs; sigma is {r.sigma:.2f} std, "
          f"{r.sigma / r.copy_last:.0f}x a real frame's change")

# %% [markdown]
# One cause we measured is width. CCNet's 1x1 encoder passes each frame through C numbers,
# and its blocks carry C channels. How much of the normalised frames can *no* linear code of C
# numbers carry (the PCA residual over the training frames, RMS per channel in training std)?

# %%
varying = ~norm.constant_channels()
train_frames = norm.norm_x(ds.x[np.concatenate([np.arange(r.start, r.stop) for r in ds.clips.itertuples()
                                                if r.split == "train"])])[:, :len(varying)][:, varying]
residual = linear_code_residual(train_frames[::5], [32, 48, 96, 128, 192, 256])
print("beyond a linear code of C numbers (RMS, training std): "
      + ", ".join(f"C = {k}: {v:.3f}" for k, v in residual.items()))
print("committed: " + ", ".join(f"{name} C = {m.cfg.channels}" for name, (m, _) in compared.items()))

# %% [markdown]
# So the default width cannot even carry a frame, and the wide one only roughly. Width is not
# the whole story, though: in a run of the paper's width (C = 256, config `paper_width`) the
# validation NLL fell far below both committed models' while its one-step rotation error
# stayed near theirs, and runs without dropout and with beta-NLL (`TrainConfig.nll_beta`, which
# keeps a large $\sigma$ from silencing the pull on an unfitted mean) that changed neither the
# one-step error nor the freezing.

# %% [markdown]
# **A network that tracks its input.** `ccnet_next_frame_cpu` is the paper's network with two
# named deviations: its mean is $\mathbf x_t$ plus the decoder's output (`CCNetConfig.residual`),
# and it is 96 channels wide (skip 128), trained for 80 CPU minutes on windows of 120 frames
# (config `next_frame_cpu`, models/README.md). Its one-step table on the same validation clips,
# then the committed full table of every model on the validation and test clips
# (`python -m data_prep one-step`, `results/ccnet_one_step.csv`):

# %%
nf_model, nf_norm, _ = zoo.load("ccnet_next_frame_cpu", retrain_if_missing=False)
nf = one_step_table(nf_model, nf_norm, ds, val_rows)
print(nf.round(4).to_string())
for block in ("rot", "pos", "all"):
    r = nf.loc[block]
    print(f"{block}: mean error {r.mean_error:.4f} std, copy-last {r.copy_last:.4f} "
          f"({'below' if r.mean_error < r.copy_last else 'ABOVE'}), constant velocity {r.extrapolate:.4f} "
          f"({'below' if r.mean_error < r.extrapolate else 'ABOVE'})")
one_step_csv = Path("../results/ccnet_one_step.csv")
if one_step_csv.is_file():
    full = pd.read_csv(one_step_csv)
    print(full.pivot_table(index=["split", "block"], columns="model", values="mean_error").round(4).to_string())

# %% [markdown]
# ## 5c · Running free: where the error grows (drift)
#
# The one-step table feeds true frames. `one_step.drift_table` lets the network run on its own
# means from frame 48 of 120-frame validation windows (with the windows' own trajectory
# controls) and sets its error at each depth beside the error of standing still at the last
# true frame. A network that does not track its input starts far behind standing still and
# stays at a constant error: it has slid to a pose of its own (freezing). One that tracks its
# input but drifts beats standing still for some frames and then falls behind it for good.

# %%
from mocapviz.tasks.one_step import drift_table

DRIFT_DEPTHS = (1, 5, 10, 30, 71)
drift = {}
for name, (m, nm) in compared.items():
    windows = WindowData(ds, 120, normaliser=nm, phase=m.cfg.phase)
    pick = np.random.default_rng(0).choice(len(windows.val), size=min(64, len(windows.val)), replace=False)
    drift[name] = drift_table(m, windows, windows.val[pick], start=48, depths=DRIFT_DEPTHS)
print(pd.concat(drift, axis=1).round(3).to_string())
for name, t in drift.items():
    ratio = t["free_running"] / t["stand_still"]
    print(f"{name}: free-running error / standing still at depth 1, 10, 71: "
          + ", ".join(f"{ratio[d]:.1f}x" for d in (1, 10, 71)))

# %% [markdown]
# ## 5d · The phase: why the phase models keep moving
#
# A network that regresses the mean of the next frame averages the continuations it cannot tell
# apart. Once its own blurred output is its past, it cannot tell where in the gait cycle it is,
# the average over the cycle is a still pose, and it freezes. `ccnet_phase` and `ccnet_phase_lerp` are told where they are:
# `mocapviz.features.phase` takes the first principal component of the clip's root-relative joint
# positions (signed so that it moves the left foot forward), and its phase (the Hilbert phase
# after a 0.4-4 Hz band-pass; for a seed shorter than 4 s, one fitted sinusoid) joins the control
# $\mathbf c^d$ as $(\sin p, \cos p)$. The decoder's weights are a Fourier series in $p$ (two
# harmonics, `CCNetConfig.phase_harmonics`, after PFNN's phase-functioned weights), so even a
# causal stack that has stalled decodes a cycle of poses. In generation the phase starts as the
# seed's and turns on at the seed's own pace (`Generator(phase_source="seed_pace")`); the
# alternative is to feed back the phase the network predicts (`"network"`).
#
# A real walk's signal and phase (left), and the phase the generator feeds over the first seconds
# of the Bandai walk seed of section 4 (right):

# %%
from mocapviz.features.phase import LEFT_FOOT, RIGHT_FOOT, local_phase, phase_signal

walk_row = ds.clip_row(walk_take)
walk_x = ds.clip_arrays(walk_row)["x"]
t_walk = np.arange(len(walk_x)) / 60
fig, axes = plt.subplots(1, 2, figsize=(12, 3))
axes[0].plot(t_walk, phase_signal(walk_x, ds.layout), label="main component of the pose (m)")
axes[0].plot(t_walk, local_phase(walk_x, ds.layout) / np.pi, lw=0.8, label="phase / pi")
foot = walk_x[:, ds.layout.x_blocks["pos"]].reshape(len(walk_x), -1, 3)
axes[0].plot(t_walk, foot[:, LEFT_FOOT, 2] - foot[:, RIGHT_FOOT, 2], ls=":", label="left foot ahead of right (m)")
axes[0].set_xlabel(f"time (s), {walk_take}")
axes[0].legend(fontsize=7)
fed = generated["bandai (held-out take)"]["out"].phase[0]
axes[1].plot(np.arange(len(fed))[:300] / 60, np.arctan2(fed[:300, 0], fed[:300, 1]) / np.pi)
axes[1].axvline(SEED_FRAMES / 60, color="grey", lw=0.5)
axes[1].set_xlabel("time (s; seed before the grey line)")
axes[1].set_ylabel("phase fed / pi")
fig.tight_layout()
show_figure(fig)

# %% [markdown]
# Which part matters, on the same ten test seeds (mean output, seconds to the end of the
# generation as in section 5): the phase turning at the seed's pace against the network's own
# predicted phase (which can stall with the pose).

# %%
by_source = {src: generation_quality(gen_model, gen_norm, ds, secs, sample=False, banks=banks, phase_source=src)["per_clip"]
             for src in ("seed_pace", "network")}
print(pd.concat({src: pd.DataFrame(q).T[["type", "freezing_share", "activity_ratio", "jitter_ratio",
                                        "root_speed_ratio"]] for src, q in by_source.items()}, axis=1).round(2))
for src, q in by_source.items():
    print(f"phase_source={src}: {sum(map(moves_like_real, q.values()))} of {len(q)} move like the real clips; "
          f"{sum(c['freezing_share'] > 0 for c in q.values())} freeze at times")

# %% [markdown]
# ## 5e · Sampling: a new $z$ every frame shakes, a blended $z$ moves
#
# Both phase models are conditional VAEs on the causal stack: in training a posterior that sees
# the true next frames gives $z$, in generation the prior $\mathcal N(0, I)$ does (sampling draws
# it; the mean output takes its mean, 0), and the frame written is the decoder's mean.
# `ccnet_phase` has one $z$ per frame. Its posterior then carries each frame's own residual, and
# independent draws from the prior turn into a kick every frame: jitter several times the real
# clips'. `ccnet_phase_lerp` has one $z$ per *knot*, 10 frames apart, and a frame between two knots
# sees their linear blend (`CCNetConfig.latent_lerp`, `mocapviz.models.ccnet.latent_weights`), in
# training and in generation: a new draw bends $z$'s path but never jumps it. Its predicted
# trajectory control (the free-running plan) is decoded without $z$ (`traj_without_z`): with
# $z$ in it, the mean output's $z = 0$ planned an average pace, and the run slowed to a third.
# Sampled jitter per seed, both models, against the moving bar's 3x:

# %%
sampled = {"ccnet_phase (z per frame)": other_quality["ccnet_phase", "sample"],
           "ccnet_phase_lerp (blended z)": quality["sample"]["per_clip"]}
fig, ax = plt.subplots(figsize=(10, 3.2))
width = 0.4
for k, (label, q) in enumerate(sampled.items()):
    ax.bar(np.arange(len(q)) + (k - 0.5) * width, [c["jitter_ratio"] for c in q.values()], width, label=label)
ax.axhline(3, color="crimson", ls="--", label="3x the real clips'")
ax.set_yscale("log")
ax.set_xticks(np.arange(len(q)), [c["type"] for c in q.values()], fontsize=8)
ax.set_ylabel("sampled jitter / real")
ax.legend(fontsize=7)
fig.tight_layout()
show_figure(fig)
for label, q in sampled.items():
    ok = sum(map(within_issue_bar, q.values()))
    print(f"{label}: sampled, {ok} of {len(q)} seeds within the moving bar (never frozen, activity 0.5-2x, "
          f"jitter <= 3x); {sum(map(moves_like_real, q.values()))} pass moves_like_real")

# %% [markdown]
# Look, too: `ccnet_phase_lerp`'s sampled walk, run and waving seeds over the last 2 s of their
# generation, each with its numbers (ratios to the real clips of its type):

# %%
shown = {}  # motion type -> its first sampled Bandai seed
for clip, c in quality["sample"]["per_clip"].items():
    if c["type"] in ("walk", "jog", "wave") and clip.startswith("dataset-") and c["type"] not in shown:
        shown[c["type"]] = clip
for kind, clip in shown.items():
    c, m = quality["sample"]["per_clip"][clip], quality["sample"]["motions"][clip]
    path = fig_dir / f"ccnet_sampled_{kind}_strip.png"
    scene.frame_strip(m[-120:], path, n=8)
    print(f"{clip} ({kind}), sampled: activity {c['activity_ratio']:.2f}x, jitter {c['jitter_ratio']:.2f}x, "
          f"pose distance {c['pose_distance_ratio']:.2f}x, root speed {c['root_speed_ratio']:.2f}x")
    display(Image(filename=str(path)))

# %% [markdown]
# ## 5f · The `generate` command's model: every body at many sizes, the root from the past, at the seed's pace
#
# Three things the seeds above show went wrong, and what `mocapviz generate` does about them:
#
# * **The body.** 90 % of the training frames are Bandai's one body, and `ccnet_phase_lerp`
#   learnt its root height, not the body's: the held-out HDM05 subject sinks and bends its knees.
#   `ccnet_phase_lerp_scale` (config `phase_lerp_scale`) trained on every
#   window's body and motion scaled by a random factor in 0.9-1.25 (`TrainConfig.body_scale`,
#   `WindowData.scaled`: exact, the same rotations on longer bones), so it sees root height,
#   pace and $\mathbf c^s$ change together.
# * **The root.** A knot of $z$ spans 10 frames, so the decoder read the root's pace from $z$, and
#   the mean output's $z = 0$ decoded an average pace: the waving walked off. The command's model,
#   `ccnet_phase_lerp_scale_root` (config `phase_lerp_scale_root`), decodes the root without $z$
#   (`CCNetConfig.root_without_z`); the table below the next cell prints the teacher-forced root
#   error of both on the training clips of the standing types
#   (`mocapviz.tasks.one_step.root_bias_table`).
# * **The pace.** Free-running, the network's own plan $\hat{\mathbf c}^d$ is fed back to it, and
#   where it plans a little slower than it goes, it slows down: runs end up jogging in place.
#   `pace="seed"` (`Generator`, `mocapviz.tasks.generate.at_speed`) scales each predicted plan to
#   the speed of the plan the seed's last frame had, as the paper's interactive control scales
#   the plan to the user's speed (§4.4); the direction stays the network's.
# * **The type.** The root fixed, the waving still stepped its feet in place: every other
#   channel is decoded from $z$, and $z$ drawn around $0$ decodes an average of all types. The
#   model's type prior (`mocapviz.models.type_prior`, fitted after training by `python -m data_prep
#   fit-type-prior`) is each motion type's aggregate posterior over the training clips, one
#   Gaussian per type; the mean output decodes the type's mean $z$, and samples draw around it.
#   It also keeps each type's usual phase pace, for a seed that shows no step cycle of its own
#   (a run from a standing start).
#
# The same ten test seeds, mean output and sampled (the command's temperature, chosen on the
# validation seeds, `mocapviz.tasks.generation_defaults`), with the network's own pace and held,
# and sampled from N(0, I) instead of the type prior:

# %%
cmd_model, cmd_norm, _ = zoo.load(GENERATION_MODEL, retrain_if_missing=False)
runs = {(pace, mode): generation_quality(cmd_model, cmd_norm, ds, secs, sample=mode == "sample", banks=banks,
                                        pace=pace, temperature=SAMPLING_TEMPERATURE)
        for pace in ("network", "seed") for mode in ("mean", "sample")}
runs["seed", "sample at temperature 1"] = generation_quality(cmd_model, cmd_norm, ds, secs, sample=True, banks=banks,
                                                             pace="seed")
runs["seed", "sample from N(0, I)"] = generation_quality(cmd_model, cmd_norm, ds, secs, sample=True, banks=banks,
                                                         pace="seed", temperature=SAMPLING_TEMPERATURE, type_prior=False)
standing = np.flatnonzero((ds.clips.type.isin(["wave", "raise_hand", "gesture"]) & (ds.clips.split == "train")).values)
print(pd.concat({name: root_bias_table(*zoo.load(name, retrain_if_missing=False)[:2], ds, standing)
                 for name in ("ccnet_phase_lerp_scale", GENERATION_MODEL)}).round(3))
for (pace, mode), q in runs.items():
    c = q["per_clip"]
    print(f"{GENERATION_MODEL}, pace {pace:7s}, {mode:26s}: {sum(map(within_issue_bar, c.values()))} of {len(c)} "
          f"within the moving bar, {sum(map(moves_like_real, c.values()))} move like the real clips; root speed "
          f"{min(v['root_speed_ratio'] for v in c.values()):.2f}-{max(v['root_speed_ratio'] for v in c.values()):.2f}x")
print(pd.concat({f"{pace}, {mode}": pd.DataFrame(q["per_clip"]).T[["activity_ratio", "jitter_ratio", "root_speed_ratio",
                                                                  "root_height_ratio"]]
                 for (pace, mode), q in runs.items() if mode == "mean"}, axis=1).round(2))
print("the waving, sampled at the seed's pace, with the type prior and from N(0, I):")
print(pd.concat({mode: pd.DataFrame(runs["seed", mode]["per_clip"]).T.query("type == 'wave'")[
    ["activity_ratio", "jitter_ratio", "root_speed_ratio"]].astype(float).round(2)
    for mode in ("sample", "sample from N(0, I)")}, axis=1))

# %% [markdown]
# Look: the held-out subject's jog and the Bandai run, mean output at the seed's pace, the last 2 s
# of the generation:

# %%
for clip, c in runs["seed", "mean"]["per_clip"].items():
    if c["type"] != "jog":
        continue
    path = fig_dir / f"ccnet_command_{clip}_strip.png"
    scene.frame_strip(runs["seed", "mean"]["motions"][clip][-120:], path, n=8)
    print(f"{clip}: activity {c['activity_ratio']:.2f}x, jitter {c['jitter_ratio']:.2f}x, root speed "
          f"{c['root_speed_ratio']:.2f}x, root height {c['root_height_ratio']:.2f}x the seed's")
    display(Image(filename=str(path)))

# %% [markdown]
# ## 6 · How this compares with the paper
#
# * **Data.** The paper trains on 486k frames of 12 subjects with long, mixed recordings. Dataset
#   v4 has about 432k frames at 60 fps, 94 minutes for training, but 90 % of it is Bandai's one
#   skeleton (three actors); HDM05 gives short single-action clips of three training actors and
#   CMU a handful of short clips. Skeleton conditioning is learnt from few bodies.
# * **Training.** Minutes on one CPU core (see `models/README.md` for the committed run), against
#   the paper's 2000 epochs on a GPU.
# * **Generation.** The paper generates "more than 20,000 frames" of motion that does not freeze.
#   Without a phase, ours froze on most seeds with the mean output (section 5 prints
#   `ccnet_default`'s and `ccnet_wide`'s counts); section 5d prints `ccnet_phase_lerp`'s with the phase
#   fed either way. What the numbers do not show, the film strips do: with `ccnet_phase_lerp` the held-out HDM05 subject's
#   body keeps moving, its legs stepping under a body that leans back with the knees bent
#   forward, and it jogs and hops nearly in place (root speed); section 5f shows the `generate`
#   command's model on the same seeds. (Until the foot IK re-planted a
#   held foot that drifts more than `mocapviz.ik.MAX_SLIP`, the IK pinned the feet of a body
#   gliding with both feet labelled in contact and stretched its legs out level behind it; the
#   raw network output never did that.) Sampling draws $z$ and writes the decoder's mean, which is far
#   less noisy than sampling the frame from the predicted Gaussian (our $\sigma$ is far above a
#   real frame's change, section 5b); with a $z$ per frame (`ccnet_phase`) it still jitters
#   several times more than real motion, with a blended $z$ (`ccnet_phase_lerp`) not on most
#   seeds (section 5e prints which).
#   `docs/experiments.md` records what else we tried: a residual
#   mean (on every channel it drifts without bound; on the rotations and positions only it never
#   freezes but tumbles through impossible poses, 6-26x the real pose distance; a leak,
#   mean = g x_t + output with g = 0.9 or 0.98, freezes every seed), constant input offsets as
#   noise (no effect on the drift), training on its own predictions (`feedback_passes`), and on
#   whole free-running stretches of each window with the data as target (`rollout_from`: the
#   one-step error rose and the drift came sooner, section 5c's measure), a per-frame latent
#   $z$ drawn instead of the frame (`TrainConfig.latent`, a conditional VAE on the causal stack:
#   sampled frames then vary by $z$ rather than by per-frame noise, but the mean output still
#   froze on most seeds), and the phase as an input only (the network then barely used it:
#   `docs/experiments.md` has the runs).
# * **Speed.** The incremental generator (each block keeps its past inputs) makes a frame cost one
#   small matmul chain per block: thousands of frames per second on a laptop CPU, against the
#   ~65 fps the paper reports for its LibTorch demo.
