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
QUICK = True     # quick: committed checkpoint, the quick dataset, a 60-step demo of the training loop
RETRAIN = False  # True: train the paper's network from scratch (its recipe in mocapviz.zoo.RECIPES) instead of loading it
FIG_DIR = "../figures"

# %% [markdown]
# # 02 · CCNet's method: representation, network, loss and training (§3, §4.2)
#
# CCNet models human motion **one frame at a time**: given the previous frames
# $\mathbf X = \{\mathbf x_{n-l-1},\dots,\mathbf x_{n-1}\}$ and the control signal $\mathbf c_n$ of the
# frame to predict, the network outputs a diagonal Gaussian over the next frame,
# $p(\mathbf x_n\mid\mathbf X,\mathbf c_n)=F_\theta(\mathbf X,\mathbf c_n)$ (Eq. 1). Because the
# control includes the **skeleton configuration** of the subject, one network models the motion
# of many different bodies. Generation feeds each predicted mean back as the next input.
#
# This notebook walks through the paper's method as implemented here, on the real HDM05 + CMU +
# Bandai data of notebook 01: the frame vector and the controls (§3.1), the network (§3.2,
# Eq. 2-5), the loss (§3.3, Eq. 6-10) and training (§4.2), with the committed model of the
# paper's network, `ccnet_paper`. Long generation with the recommended model and the measures
# of whether generated motion moves like a person are notebook `02_motion_generation`; the
# model-by-model history of how that model came about is the appendix notebook
# `appendix_generation_history` (run on demand).

# %%
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from IPython.display import display

from data_prep import zoo
from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from mocapviz.models.ccnet_config import make_config, receptive_field
from mocapviz.models.protocol import count_parameters
from mocapviz.zoo import RECIPES, train_command
from mocapviz.training.config import TRAIN_CONFIGS
from mocapviz.training.trainer import evaluate, train
from mocapviz.training.windows import WindowData
from mocapviz.viz import scene, show_figure
from mocapviz.viz.ccnet import plot_controls, plot_training_curves

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
print("pyvista backend:", scene.set_notebook_backend(QUICK))
PAPER = pd.read_csv("../results/paper_ccnet_setup.csv").set_index("quantity")  # the paper's own numbers


def paper(quantity: str) -> str:
    """The paper's number for ``quantity`` (results/paper_ccnet_setup.csv), with its unit and section."""
    r = PAPER.loc[quantity]
    return f"{r.value:,g} {r.unit} ({r.section})"


MODEL = "ccnet_paper"  # the paper's network, as committed (models/README.md)

# %% [markdown]
# ## 1 · The frame vector $\mathbf x_n$ and the control $\mathbf c_n$ (§3.1)
#
# The dataset build (`python -m data_prep build ccnet`, cached under `cache/ccnet/`) keeps
# CCNet's joints, resamples every clip to the dataset's frame rate and computes, per frame, in
# the **previous frame's heading frame** (a Y-up frame on the ground under the previous root,
# turned to the direction the body faced):
#
# * $\mathbf x^e$ exponential-map local joint rotations (the root's relative to its heading),
#   $\mathbf x^\omega$ their angular velocities, $\mathbf x^p$ joint positions relative to the
#   previous root frame, $\mathbf x^v$ joint linear velocities, $\mathbf x^f$ the foot contacts;
# * a **root** block (planar velocity, heading rate, root height): what generation integrates
#   into the path.
#
# The control is $\mathbf c^s$ (root height + root-relative rest joint positions), the
# trajectory $\mathbf c^d$ (where the root will be at a few frames ahead, in the current heading
# frame), and a one-hot motion type over our merged types (HDM05's classes with CMU's
# walk/run/jump/kick mapped in, then Bandai's contents appended; Bandai's run counts as jog and
# its turning walks as walk). The layout table gives every block's channels and units:

# %%
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
layout = ds.layout
display(pd.DataFrame(layout.table(), columns=["block", "start", "stop", "unit"]))
m = ds.meta
print(f"{layout.n_joints} joints at {ds.config.fps:g} fps; "
      f"{len(ds.motion_types)} motion types: {', '.join(ds.motion_types)}")
print(f"{len(ds.clips)} clips, {m['n_frames']} frames ({m['n_frames'] / ds.config.fps / 60:.1f} min), "
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
# * **Encoder** (Eq. 2): dropout on the input frames, then Conv1D $k{=}1$ + ReLU.
# * **Separate residual blocks** (Fig. 2): a dilated *causal* Conv1D with kernel 2 (output $t$
#   sees inputs $t$ and $t-d_i$), plus each control type through **its own** Conv1D $k{=}1$,
#   summed in; WaveNet's gated unit $\tanh(\cdot)\odot\sigma(\cdot)$; a residual 1×1 back to the
#   block input and a skip 1×1 out.
# * **Skip sum** (Eq. 4) → **decoder** (Eq. 5): ReLU + Conv1D $k{=}1$ giving the mean, $s$ with
#   $\hat\sigma = e^{-s}$ clipped from below, the foot-contact logits, and the predicted
#   trajectory control $\hat{\mathbf c}^d$ (mean and $\sigma$).
#
# The causal receptive field is $CRL=(k-1)+\sum_i d_i(k-1)$ (Eq. 3), printed below for the
# paper's stack and the two alternatives of its §4.8.1. Note what the paper's choice implies:
# with every $d_i = 2$ the output at $t$ depends on inputs $t, t-2, \dots$ only, so the span
# holds about twice as many frames as the network actually sees.
#
# `ccnet_paper` is the paper's network with two named deviations, both printed against the
# paper's configuration: its mean is $\mathbf x_t$ plus the decoder's output
# (`CCNetConfig.residual`), and it is narrower (the width a CPU could train;
# [docs/method.md](../docs/method.md) says why each deviation).

# %%
model, norm, meta = zoo.load(MODEL, retrain_if_missing=RETRAIN, prefer_committed=not RETRAIN)
cfg = model.cfg
ds = ds.with_vocabulary(cfg.n_types)  # the clips of the types the model knows
paper_cfg = make_config("paper")
arch = ("channels", "skip_channels", "kernel_size", "dropout", "residual", "latent", "phase")
table = pd.DataFrame({MODEL: [getattr(cfg, f) for f in arch], "the paper's network": [getattr(paper_cfg, f) for f in arch]},
                     index=list(arch))
table.loc["blocks (SRBs)"] = [len(cfg.dilations), len(paper_cfg.dilations)]
table.loc["dilations"] = [sorted(set(cfg.dilations)), sorted(set(paper_cfg.dilations))]
table.loc["CRL (Eq. 3)"] = [cfg.receptive_field, paper_cfg.receptive_field]
print(table.to_string())
print(f"{MODEL}: {count_parameters(model):,} parameters")
def inputs_seen(dilations) -> int:
    """How many of the frames in the receptive field the output reads (kernel 2: every sum of a subset of the d_i)."""
    lags = {0}
    for d in dilations:
        lags |= {lag + d for lag in lags}
    return len(lags)


for d in [(2,) * 20, (1, 2) * 10, (1, 2, 4) * 6 + (1, 2)]:
    print(f"  {len(d)} blocks, dilations {d[:4]}...: CRL = {receptive_field(d)}, frames read = {inputs_seen(d)}")
ckpt = zoo.committed_path(MODEL)
if ckpt.is_file():
    print(f"committed checkpoint {ckpt.name}: {ckpt.stat().st_size / 2**20:.2f} MB, the best-by-validation "
          f"model of a {meta.get('final_step', meta['step'])}-step run: step {meta['step']}, validation NLL "
          f"{meta.get('val_nll')}, test NLL {meta.get('test_nll')}; command: {train_command(MODEL)}")

# %% [markdown]
# ## 3 · Loss and training (§3.3, §4.2)
#
# $L = L_G + \lambda_s L_s + \lambda_f L_f + \lambda_d L_d$: Gaussian NLL of the next frame
# (Eq. 7), smoothness of the predicted means (Eq. 8), foot-contact BCE (Eq. 9), and the Gaussian
# NLL of the predicted trajectory control (Eq. 10), with the paper's weights (`TrainConfig.lambdas`,
# printed below). Eq. 8 as printed sums *signed* second differences, which can go negative; we
# penalise their **square, averaged over channels** (summed over every channel, it made an early
# model output a constant mean). The channels that never vary in the training data (rotations of
# joints without rotational freedom) are left out of $L_G$ and $L_s$: kept in, their $\sigma$
# shrank towards zero and bought a large NLL gain for nothing (`docs/method.md`). Whole windows
# at once (causality makes every output a valid next-frame prediction), i.i.d. Gaussian noise on
# the normalised inputs.
#
# Optimiser: the `paper` config keeps the paper's RMSprop and learning-rate schedule. The CPU
# configs start at a higher rate (a CPU budget of a few thousand steps gets nowhere at the
# paper's) and therefore use **Adam**: torch's RMSprop has no bias correction, and at that rate
# it could not even overfit one training clip (`tests/test_ccnet_training.py`). The configs,
# then the paper's own settings:

# %%
shown = [k for k in ("paper", "paper_next_frame", "default", "quick") if k in TRAIN_CONFIGS]
columns = [f.name for f in fields(TRAIN_CONFIGS["paper"])
           if f.name in ("size", "steps", "batch_size", "window", "lr", "lr_final", "noise_std", "lambdas",
                         "optimizer", "residual", "minutes")]
print(pd.DataFrame({k: {f: getattr(TRAIN_CONFIGS[k], f) for f in columns} for k in shown}).to_string())
print(f"{MODEL} was trained with config {RECIPES[MODEL][0]!r}")
print("the paper: " + "; ".join(f"{q.replace('_', ' ')} {paper(q)}" for q in ("epochs", "batch_size", "window", "input_noise_std")))

# %% [markdown]
# The curves: the committed run's losses (training and validation), and in quick mode a short
# demonstration of the training loop itself on the quick dataset.

# %%
curves = {f"{MODEL} (committed)": ckpt.with_name(f"{MODEL}_losses.csv")}
if QUICK:
    demo = replace(TRAIN_CONFIGS["quick"], steps=60, eval_every=30, checkpoint_every=30)
    t = time.perf_counter()
    train(ds, demo, "../cache/runs/notebook_demo", resume=False)
    print(f"{demo.steps} quick steps in {time.perf_counter() - t:.0f} s")
    curves[f"quick, {demo.steps}-step demo"] = Path("../cache/runs/notebook_demo/losses.csv")
fig = plot_training_curves({k: v for k, v in curves.items() if v.is_file()}, path=fig_dir / "ccnet_training_curves.png")
show_figure(fig)

# %% [markdown]
# Model selection uses the **validation** split only: the trainer evaluates the validation NLL
# (the held-out HDM05 actor *mm* plus a share of Bandai takes) on its schedule and keeps the
# model with the lowest as `best.safetensors`; that is the model `--export` commits. The test NLL
# (the held-out subject, one clip of each other subject, a share of Bandai takes) is logged for
# reporting only. $L_G$ is in nats per frame over the varying normalised channels. Our NLL per
# held-out group, then the loss the paper reports on *its* test split (its frame vector, its
# data: the numbers are not comparable, only their order of magnitude):

# %%
data = WindowData(ds, min(60, ds.config.window), normaliser=norm, phase=cfg.phase)
held_out = ds.clips.subject.values[data.test[:, 0]] == ds.meta["test_subject"]
splits = {"validation": data.val, "test": data.test, f"test, subject {ds.meta['test_subject']}": data.test[held_out],
          "test, other subjects and Bandai takes": data.test[~held_out]}
print(pd.DataFrame({k: {"windows": len(p), **evaluate(model, data, p)} for k, p in splits.items()}).T.round(2))
print(f"the paper: L about {paper('typical_loss')}")

# %% [markdown]
# ## 4 · Our data and training beside the paper's
#
# The paper trains on its own recordings of its subjects, long takes that mix motion types;
# ours are public datasets: Bandai's takes all share one skeleton (in the full dataset they are
# most of the frames; the quick one keeps three takes per content), HDM05 gives short
# single-action clips of a few actors and CMU a handful of clips, so skeleton conditioning is
# learnt from few bodies. Training here is CPU minutes against the paper's GPU epochs. From the
# dataset and the checkpoint (in quick mode, the quick dataset):

# %%
bandai = (ds.clips.source == "bandai").values
frames = (ds.clips.stop - ds.clips.start).values
print(pd.DataFrame({
    "paper": [paper("dataset_frames"), paper("subjects"), "-", paper("epochs")],
    "ours": [f"{frames.sum():,} frames", f"{ds.clips.loc[~bandai, 'subject'].nunique() + int(bandai.any())} bodies",
             f"{frames[bandai].sum() / frames.sum():.0%}", f"{meta.get('final_step', meta['step']):,} steps"],
}, index=["frames", "bodies (Bandai's one skeleton counted once)", "frames from one skeleton (Bandai)",
          "training"]).to_string())

# %% [markdown]
# Next: notebook `02_motion_generation` runs the recommended model free for many seconds on
# three bodies and measures, on the poses, whether the result moves like real motion, beside
# this notebook's `ccnet_paper`.
