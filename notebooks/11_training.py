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
QUICK = True  # quick: reconstruct the quick dataset's test cycles; full: every test cycle of the full dataset
FIG_DIR = "../figures"

# %% [markdown]
# # 11 · The 4D motion CVAE: representation, architecture, two-phase training (§3.2-3.3, §4.2)
#
# One latent vector $z$ encodes a whole **gait cycle of a body mesh sequence**. A cycle is
# $[\beta, \chi]$ with $\chi = [\Theta, \Gamma, \Phi]$ (notebook 10): 100 frames of joint
# rotations (6-D, minus the identity), root translations (first frame at 0, scaled into
# $[-1, 1]$) and timestamps (seconds / 3), on the body shape $\beta$ (anny's 6 phenotypes).
#
# **Architecture** (Fig. 2): an MLP encoder $\chi \mapsto (\mu, \log\sigma^2)$ of $z \in \mathbb R^{64}$,
# $z = \mu + \epsilon\sigma$, and an MLP decoder $[z, \beta] \mapsto \hat\chi$, ReLU between layers.
# The encoder is **not conditioned on $\beta$**, the decoder is. A CVAE would condition both;
# the paper found that this cost accuracy and explains why: CVAE conditions are usually a few
# discrete classes, each with many examples, whereas $\beta$ is continuous and each body has
# only a few cycles, so a latent distribution *per body* $p(z \mid \chi, \beta)$ cannot be learnt.
# The encoder learns $p(z \mid \chi)$ as a plain VAE; the decoder still learns how motion depends
# on the body, $p(\chi \mid z, \beta)$.
#
# **Training** in two phases:
#
# 1. $\mathcal L_{init} = \omega_{pose}\mathcal L_{pose} + \omega_{trans}\mathcal L_{trans} +
#    \omega_{time}\mathcal L_{time} + \omega_{KL}\mathcal L_{KL}$ (Eq. 1, 4) on $\chi$: squared L2 of
#    each part; Adam $10^{-3}$, batch 256;
# 2. $\mathcal L = \omega_{spatial}\,\|M - \hat M\|^2 + \omega_{time}\mathcal L_{time} + \omega_{KL}\mathcal L_{KL}$
#    (Eq. 2, 3, 5) on the meshes in metres, through a differentiable $\chi \to$ mesh path in
#    torch (`mocapviz.bodies.torch_mesh`); Adam $10^{-4}$, batch 16.
#
# The $\omega$ of the partial losses are adaptive, by **GradNorm** (Chen et al. 2018,
# `mocapviz.training.gradnorm`): each weight moves so that the weighted gradient norms at the
# decoder's last hidden layer follow each loss's relative training rate to the power
# $\alpha$ (printed below from the checkpoints; `python -m data_prep train-cvae --alpha-sweep`
# scores alphas on the validation cycles); weights sum to the number of tasks and restart
# at 1 in phase 2. $\omega_{KL} = 0.01$
# is fixed; the paper's "squared KL" we read as the closed-form KL of $\mathcal N(\mu, \sigma^2)$
# to $\mathcal N(0, 1)$, summed over $z$ (`mocapviz.models.cvae4d.kl_divergence` says why).

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep.body4d_dataset import Body4DConfig, build_dataset
from mocapviz.bodies import body_model
from mocapviz.bodies.representation import split_chi
from mocapviz.bodies.torch_mesh import ChiMesher, chi_times
from mocapviz.models.protocol import count_parameters
from mocapviz.tasks.cvae4d_eval import on_scale, reconstruct_cvae, test_sets, vertex_errors
from mocapviz.training.cvae4d import TASKS, data_fingerprint, split_indices
from mocapviz.zoo import cvae4d_epochs, find_checkpoint, load_cvae4d
from mocapviz.viz import cycle_strips, save_figure, set_notebook_backend

torch.set_num_threads(2)
set_notebook_backend(QUICK)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 160)

# %% [markdown]
# ## The data and its representation
#
# The dataset of notebook 10 (quick mode: its small build). Training uses the cycles whose
# `split` is `train`; `val` cycles choose the epoch kept; the `test` ones form the test sets of the
# `test_set` column (held-out subjects HDM05 tr, CMU 35 and 09; held-out Bandai takes on Bandai's
# body and on a held-out subject's body), mirrored copies left out.

# %%
body = body_model()
# quick: the small build (seconds; its test split is a few cycles)
ds = build_dataset(Body4DConfig.quick() if QUICK else Body4DConfig())
train_idx, held_idx = split_indices(ds)
sets = test_sets(ds)
n_kept = len(ds.meta["chi_joints"])
print(f"{len(ds)} cycles: {len(train_idx)} for training, test sets "
      f"{ {k: len(v) for k, v in sets.items()} }; chi per cycle {ds.chi.shape[1]} x {ds.chi.shape[2]} "
      f"= {ds.chi.shape[1] * ds.chi.shape[2]} numbers ({ds.meta['chi_layout']}), beta {ds.beta.shape[1]}")
print("types in training:", ds.cycles.iloc[train_idx]["type"].value_counts().to_dict())
print("types in test:", ds.cycles.iloc[np.concatenate(list(sets.values()))]["type"].value_counts().to_dict())

fig, axes = plt.subplots(1, 3, figsize=(13, 3.2))
for t in ds.cycles["type"].unique():
    i = int(ds.cycles.index[ds.cycles["type"] == t][0])
    theta, gamma, phi = split_chi(ds.chi[i], n_kept)
    axes[0].plot(phi * 3, gamma[:, 2] * ds.gamma_scale[2], label=t)
    axes[1].plot(phi * 3, gamma[:, 1] * ds.gamma_scale[1], label=t)
    axes[2].plot(np.arange(100), phi * 3, label=t)
axes[0].set(xlabel="time (s)", ylabel="forward travel Γz (m)", title="Γ: translation")
axes[1].set(xlabel="time (s)", ylabel="vertical Γy (m)", title="Γ: bounce")
axes[2].set(xlabel="frame", ylabel="Φ × 3 s", title="Φ: timestamps (the cycle's duration)")
axes[0].legend(fontsize=8)
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig_representation.png")

# %% [markdown]
# ## The committed models
#
# Both phases were trained on the **full** dataset (every training cycle) by the commands printed
# below from each checkpoint's metadata (`python -m data_prep train-cvae --phase 1 ...`, then
# `--phase 2` from that run; epochs sized to one CPU thread, where the paper runs 5000 + 200 on a
# GPU). Each epoch draws the training cycles with every body equally likely and, within a body,
# a cycle of a type the body has n cycles of n^-p times as often (p printed as `balance_types`:
# without it the rare types' root translations decided how far two training seeds landed apart;
# docs/method.md). They load by name through the zoo; the notebook trains nothing. Their losses
# per epoch are the `_losses.csv` files beside them.

# %%
phase1, meta1 = load_cvae4d("cvae4d_phase1")
phase2, meta2 = load_cvae4d("cvae4d_phase2")
log1, log2 = (pd.read_csv(find_checkpoint(n).with_name(f"{n}_losses.csv")) for n in ("cvae4d_phase1", "cvae4d_phase2"))
print(phase2)
print(f"{count_parameters(phase2):,} parameters; latent {phase2.cfg.latent}, hidden {phase2.cfg.hidden}; "
      f"checkpoint {find_checkpoint('cvae4d_phase2').stat().st_size / 1e6:.1f} MB (float16)")
for name, zoo_name, meta in (("phase 1", "cvae4d_phase1", meta1), ("phase 2", "cvae4d_phase2", meta2)):
    tc = meta["train_config"]
    run, kept = cvae4d_epochs(zoo_name)
    ended = " (its time budget ended it)" if run < tc["epochs"] else ""
    print(f"{name}: {run} epochs run of the {tc['epochs']} configured{ended}, epoch {kept} kept; "
          f"batch {tc['batch_size']}, lr {tc['lr']}, KL weight {tc['kl_weight']}, "
          f"balance_types {tc.get('balance_types', 0)}, "
          f"{float(meta['seconds']) / 60:.1f} min wall on {tc['threads']} thread(s) of a shared machine; "
          f"{meta['dataset']['n_train']} training cycles of dataset {meta['dataset']['hash']}; `{meta['command']}`")
print("this notebook's dataset is the one they were trained on:",
      data_fingerprint(ds) == meta1["dataset"]["fingerprint"])

# %% [markdown]
# ## GradNorm's weights and both phases' losses
#
# Top: the adaptive weights per epoch (they sum to the number of tasks). Bottom: each task's
# training loss (squared L2 per cycle, normalised $\chi$ units in phase 1, m² summed over the
# mesh in phase 2) and, every few epochs, the same loss on the validation cycles (z = μ).

# %%
fig, axes = plt.subplots(2, 2, figsize=(13, 7))
for col, (log, phase) in enumerate(((log1, 1), (log2, 2))):
    for task in TASKS[phase]:
        axes[0, col].plot(log["epoch"], log[f"w_{task}"], label=f"ω_{task}")
        line, = axes[1, col].semilogy(log["epoch"], log[task], label=f"{task} (train)")
        held = log.dropna(subset=[f"val_{task}"]) if f"val_{task}" in log else None
        if held is not None and len(held):
            axes[1, col].semilogy(held["epoch"], held[f"val_{task}"], "--", color=line.get_color(),
                                  label=f"{task} (validation)")
    axes[0, col].set(title=f"phase {phase}: GradNorm weights", xlabel="epoch")
    axes[1, col].set(title=f"phase {phase}: task losses", xlabel="epoch")
    axes[0, col].legend(fontsize=8)
    axes[1, col].legend(fontsize=7)
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig_training.png")
for phase, log, m in ((1, log1, meta1), (2, log2, meta2)):
    print(f"phase {phase}: GradNorm alpha {m['train_config']['alpha']}; largest ratio between two weights in any "
          f"step {log['w_ratio_max'].max():.1f}x (the issue's bar: 10x)")
print("last epoch, phase 1:", log1.iloc[-1][[c for c in log1.columns if not c.startswith(("G_", "r_"))]].to_dict())
print("last epoch, phase 2:", log2.iloc[-1][[c for c in log2.columns if not c.startswith(("G_", "r_"))]].to_dict())

# %% [markdown]
# ## Reconstructions of held-out cycles
#
# Each test cycle is encoded (z = μ), decoded with its true β, and meshed with every anny
# vertex; the error is the mean distance between corresponding vertices over the 100 frames.
# Strips: 8 frames coloured dark to light in time, the truth above the two reconstructions.
# Each build scales translations by its own training cycles' extent, so the cycles are first put
# on the checkpoints' scale (`on_scale`). The quick build's test cycles are held out by the same
# rules as the full build's (same sources, subjects and Bandai takes), so the models never saw
# them; they are a few of the full test sets (notebook 12 has every test cycle).

# %%
ds_m = on_scale(ds, meta1["dataset"]["gamma_scale"])
mesher = ChiMesher(body, ds_m.gamma_scale)
test_idx = np.concatenate(list(sets.values()))
rec1 = reconstruct_cvae(phase1, ds_m.chi[test_idx], ds_m.beta[test_idx])
rec2 = reconstruct_cvae(phase2, ds_m.chi[test_idx], ds_m.beta[test_idx])
err1 = vertex_errors(mesher, ds_m.chi[test_idx], rec1, ds_m.beta[test_idx])
err2 = vertex_errors(mesher, ds_m.chi[test_idx], rec2, ds_m.beta[test_idx])
per_cycle = ds.cycles.iloc[test_idx][["subject", "type", "test_set", "duration_s"]].assign(
    phase1_mm=err1.round(1), phase2_mm=err2.round(1),
    duration_rec_s=chi_times(torch.as_tensor(rec2))[:, -1].numpy().round(2))
display(per_cycle)
print(f"mean vertex error over {len(test_idx)} test cycles: phase 1 {err1.mean():.1f} mm, phase 2 {err2.mean():.1f} mm")

# %%
picks = [int(np.argmin(err2)), int(np.argsort(err2)[len(err2) // 2])]  # the best and the median cycle
meshes, labels = [], []
with torch.no_grad():
    for k in picks:
        i = test_idx[k]
        root0 = torch.tensor([[0.0, float(ds.cycles["root0_y"].iloc[i]), 0.0]])
        beta = ds.beta[i:i + 1]
        name = f"{ds.cycles.type.iloc[i]} | {ds.cycles.subject.iloc[i]}"
        for chi, what in ((ds_m.chi[i], "truth"), (rec1[k], f"phase 1: {err1[k]:.0f} mm"),
                          (rec2[k], f"phase 2: {err2[k]:.0f} mm")):
            meshes.append(mesher(torch.as_tensor(chi)[None], beta, root0=root0)[0].numpy())
            labels.append(f"{name} | {what}")
cycle_strips(body, meshes, labels, path=fig_dir / "cvae4d_fig_reconstructions.png")
display(Image(filename=str(fig_dir / "cvae4d_fig_reconstructions.png")))

# %% [markdown]
# ## How this compares with the paper
#
# The paper trains on 13 121 AMASS cycles of hundreds of subjects (5000 + 200 epochs on a GPU);
# we train on the training cycles of notebook 10's full dataset (the count is printed above), on
# one CPU thread, for the epochs printed above, at the hidden widths and latent size printed
# above (and the checkpoint's size). The gap between the solid (training) and dashed
# (held-out) curves above is what these short runs generalise. Notebook 12 compares both phases
# with the PCA baseline on every test set (`results/cvae4d_reconstruction.csv`).
