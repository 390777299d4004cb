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
# This notebook walks through our implementation on the real HDM05 + CMU data of notebook 01:
# the frame vector and the controls, the network (Eq. 2-5), the loss (Eq. 6-10), training
# (§4.2), and long generated motion for two subjects with very different skeletons, one of
# them the held-out test subject.

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
from mocapviz.tasks.generation_quality import QUALITY_KEYS, generation_quality, real_reference
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
# kick mapped in: run → jog, jump → hop, kick → kick; CMU walk is its own type).

# %%
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
layout = ds.layout
display(pd.DataFrame(layout.table(), columns=["block", "start", "stop", "unit"]))
m = ds.meta
print(f"{len(ds.clips)} clips, {m['n_frames']} frames at 60 fps ({m['n_frames'] / 3600:.1f} min), "
      f"{m['n_train_frames']} for training; test: subject {m['test_subject']!r} (all clips) + one clip of "
      f"every other subject with two or more usable clips = {len(m['test_clips'])} clips; validation (model "
      f"selection): every other clip of a second held-out actor, {m['val_subject']!r} = "
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
# differences, which can go negative; we penalise their **square, averaged over channels**. (Summed
# over our 304 channels with weight 10, the first default run learnt to output an almost constant
# mean, zero acceleration, with a large sigma: the ReLU before the decoder died and generated
# motion shuffled in place at a fifth of the real speed.) RMSprop, whole windows at once
# (causality makes every output a valid next-frame prediction), i.i.d. N(0, 0.03²) noise on the
# normalised inputs so that the network learns to recover from its own errors.
#
# Window length (the paper's NCF = 240): many of our clips last 1-3 s, so NCF = 60 (1 s, the
# shortest the paper tried): 244 of 302 clips give windows, 93% of the frames. Schedules: the
# `paper` config keeps lr 1e-4 → 1e-6; the `default` (committed) and `quick` configs start at
# 1e-3 (same 100× decay) because a CPU budget of a few thousand steps gets nowhere at 1e-4.

# %%
print(pd.DataFrame({k: {f: getattr(c, f) for f in ("size", "steps", "batch_size", "window", "lr", "lr_final",
                                                     "noise_std")} for k, c in TRAIN_CONFIGS.items()}))
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
# Model selection uses the **validation** split only: every 250 steps the trainer evaluates the
# validation NLL (every 60-frame window of the 43 clips of the held-out validation actor *mm*,
# whom training never sees) and keeps the model with the
# lowest as `best.safetensors`; that is the model `--export` commits. The test NLL (every frame of
# non-overlapping 60-frame windows of the test clips; no noise, no dropout) is logged for
# reporting only. $L_G$ is in nats per frame over the 304 normalised continuous channels.
#
# What the curves show: the validation NLL on *mm* falls to 38 at step 1500 and then rises (181
# at step 3000), so validation selects step 1500; there the test NLL is 20 (20 on the held-out
# subject *tr*, 18 on the five windows of the other subjects' test clips; table below). The test
# curve does not follow validation exactly: it keeps falling to about −1 at step 2250 and ends at
# 29. Both held-out actors say the same thing at the scale that matters: the network overfits
# to the three training HDM05 actors' **bodies and styles** (the training $L_G$ keeps falling, to
# about −135 at step 3000),
# which is why validation holds out a whole actor (dataset v3). An earlier version validated on
# one clip of each training actor: its validation NLL fell to −297 at step 3000 while *tr* rose
# to +440, so it picked the most overfitted model. We never pick a step from the test curve. The
# paper reports $L\approx-300$ on *its* test split, with 486k training frames of 12 subjects; our
# held-out-subject NLL stays positive.

# %%
data = WindowData(ds, 60, normaliser=norm)
held_out = ds.clips.subject.values[data.test[:, 0]] == ds.meta["test_subject"]
splits = {f"validation, subject {ds.meta['val_subject']}": data.val, "test": data.test, f"test, subject {ds.meta['test_subject']}": data.test[held_out],
          "test, one clip of each other subject": data.test[~held_out]}
print(pd.DataFrame({k: {"windows": len(p), **evaluate(model, data, p)} for k, p in splits.items()}).T.round(2))

# %% [markdown]
# ## 4 · Generation for two different bodies (§4.2)
#
# Seeds: the first second of a real clip of each subject. Then 20 s of autoregressive synthesis
# (the mean of each predicted Gaussian, fed back) with the clip's motion type and the network's
# own predicted trajectory control $\hat{\mathbf c}^d$ (the paper's fallback when the user gives
# none; following user paths is notebook 04). The held-out subject *tr* (1.75 m, never seen in
# training) jogs; CMU subject 91 (1.37 m) walks. The poses come back through FK from the
# generated rotations, the path from the integrated root block, and foot sliding is cleaned
# by contact-triggered two-bone leg IK. The last column is the pose-level freezing share of the
# generated frames (section 5 explains it): watch the film strips below with it in mind.

# %%
SECONDS = 20
subjects = {
    "tr (held out)": ds.clips[(ds.clips.subject == ds.meta["test_subject"]) & (ds.clips.type == "jog")]["clip"].iloc[0],
    "cmu91": "91_02",
}
generated = {}
for label, clip in subjects.items():
    row = ds.clip_row(clip)
    r, a = ds.clips.iloc[row], ds.clip_arrays(row)
    seed, n = 60, SECONDS * 60
    t = time.perf_counter()
    out = Generator(model, norm).run(a["x"][None, :seed], a["skel"][None], one_hot([a["type_index"]], cfg.n_types), n,
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
    print(f"{label:14s} seed {clip}: {n} frames in {dt:.2f} s; height {ds.clips.height[row]:.2f} m; root speed "
          f"{speed:.2f} m/s; foot slide {slide(raw):.3f} -> {slide(clean):.3f} m/s with IK; "
          f"pose frozen in {frozen:.0%} of its 1 s windows")

# %% [markdown]
# Rendered with pyvista (quick mode: 6 frames/s and a film strip; full mode: 30 frames/s mp4).

# %%
for label, g in generated.items():
    name = g["clean"].name
    strip = scene.frame_strip(g["clean"], fig_dir / f"{name}_strip.png", n=8)
    display(Image(filename=str(fig_dir / f"{name}_strip.png")))
    paths = [fig_dir / f"{name}.gif"] + ([] if QUICK else [fig_dir / f"{name}.mp4"])
    scene.render_clip(g["clean"], paths, fps=6 if QUICK else 30, label=f"CCNet: {label}", progress=False)
    display(Image(filename=str(paths[0])))

# %% [markdown]
# ## 5 · Does it freeze? Pose-level metrics (issue 9)
#
# Autoregressive models often settle into a mean pose. The measure must read the **poses**: the
# joint positions from FK, relative to the root joint and turned into the body's heading frame
# (`mocapviz.metrics.local_positions`), so a statue gliding along its path scores as frozen. (An
# earlier version of this notebook read the network's own velocity channels instead: they settle
# to a constant non-zero value while the pose is frozen, and it reported "no freezing".)
#
# Ten test-split seeds (round-robin over motion types) are generated free-running (the network's
# own $\hat{\mathbf c}^d$), with the **mean** output and with **sampling** from the predicted
# Gaussian, and the second half is measured (`mocapviz.tasks.generation_quality`, the same code as
# `benchmarks/bench_generation.py`, which runs 60 s): the share of 1 s windows whose mean local
# joint speed is under 1 cm/s (no real clip has such a window), the activity (pose change per
# second) and jitter (second differences) as ratios to the real clips of the same type, and the
# root height relative to the seed's (a drifting body shows there).
#
# **What it shows for the committed model**: with the mean output the pose freezes within
# seconds (freezing share 1, activity ratio ~0): only the integrated root moves. Sampling does not
# freeze, but it is noise, not motion: activity tens of times and jitter hundreds of times the
# real clips'. The numbers below are computed, not typed.

# %%
secs = 20 if QUICK else 60
quality = {mode: generation_quality(model, norm, ds, secs, sample=mode == "sample") for mode in ("mean", "sample")}
for mode, q in quality.items():
    print(f"{mode} output, 10 x {secs} s, seconds {secs // 2}-{secs} (min / median / max over the seeds):")
    for key, v in q["summary"].items():
        print(f"    {key:18s} {v}")
print(pd.concat({mode: pd.DataFrame(q["per_clip"]).T[["type", *QUALITY_KEYS]] for mode, q in quality.items()},
                axis=1).round(3))
verdict = quality["mean"]["summary"]["freezing_share"][1], quality["sample"]["summary"]["jitter_ratio"][1]
print(f"mean output: median freezing share {verdict[0]:.2f} ({'frozen' if verdict[0] > 0.5 else 'moving'}); "
      f"sampling: median jitter {verdict[1]:.0f}x the real clips' ({'noise' if verdict[1] > 3 else 'plausible'})")

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
    ax.axvline(1.0, color="grey", lw=0.5)
    ax.set_title(clip, fontsize=9)
    ax.set_xlabel("time (s; seed before the grey line)")
axes[0].set_ylabel("mean local joint speed (m/s)")
axes[0].legend(fontsize=7)
fig.tight_layout()
show_figure(fig)

# %% [markdown]
# ## 6 · How this compares with the paper
#
# * **Data.** The paper trains on 486k frames of 12 subjects with long, mixed recordings; we have
#   about 37k frames at 60 fps (~10 min of HDM05 plus ~35 s of usable CMU clips; 24k frames for
#   training after the test and validation clips), mostly 1-3 s clips of single actions. Our
#   windows are 1 s (not 4 s), the network sees few transitions, and our CMU subjects contribute
#   one short clip each: skeleton conditioning is learnt from three training HDM05 bodies plus a
#   handful of CMU ones.
# * **Training.** A few thousand steps on one CPU core, against the paper's 2000 epochs on a GPU.
#   On the held-out actors our $L_G$ stays positive (about 38 on the validation actor *mm* and
#   20 on the test subject *tr* at the selected step, against the paper's ≈ −300, while the
#   training $L_G$ there is about −60 and −135 by step 3000). Part of even that is free: 44 of the
#   304 channels are constant in the training data, and the committed model was trained with them
#   in $L_G$ (their $\sigma$ shrank to ~0.002, about −218 nats per frame); the training code now
#   leaves them out.
# * **Generation.** The paper generates "more than 20,000 frames" of motion that does not freeze.
#   The committed model does not move: with the mean output its pose freezes within seconds
#   (section 5) while the root glides along the path, and sampling gives noise. The cause is in
#   training, not in the generator: teacher-forced on *training* windows, its predicted mean is
#   5-12x further from the next frame than the current frame is (issue 9's diagnosis). The
#   likeliest culprit is the optimiser: torch's RMSprop (no bias correction) at lr 1e-3 cannot
#   even overfit one training clip, Adam can (`tests/test_ccnet_training.py`), so the `quick` and
#   `default` configs now use Adam (`mocapviz/training/config.py`). A model retrained that way is
#   still to come; until then this notebook shows a model that freezes.
# * **Speed.** The incremental generator (each block keeps its past inputs) makes a frame cost one
#   small matmul chain per block: thousands of frames per second on a laptop CPU, against the
#   ~65 fps the paper reports for its LibTorch demo.
