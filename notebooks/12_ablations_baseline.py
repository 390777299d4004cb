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
QUICK = True  # quick: the committed tables; full: re-evaluate the committed checkpoints on the full dataset
FIG_DIR = "../figures"

# %% [markdown]
# # 12 · Ablations and the PCA baseline (4D motion paper §4.3-4.4, Figs. 3-5)
#
# How well does one latent vector rebuild an unseen 4D cycle? The metric is the paper's: the
# **mean vertex error per sequence**, the distance between corresponding vertices of the true
# and the reconstructed mesh sequence (every anny vertex, 100 frames), averaged, in mm; a
# reconstruction decodes $z = \mu$ with the cycle's **true** $\beta$.
#
# - Fig. 5: PCA on $[\chi, \beta]$ with $\dim z + \dim\beta$ components (scikit-learn; rebuilt with
#   the true $\beta$, §4.4) against the CVAE after phase 1 and after phase 2, on each test set
#   of the full dataset (held-out source HDM05, held-out subjects CMU 35 and 09, held-out Bandai
#   takes);
# - Fig. 3: the latent dimension, 8 / 16 / 32 / 64 / 128 (the paper keeps 64: the error stops
#   falling there);
# - Fig. 4: the KL weight, 0.001 / 0.01 / 0.1 (smaller fits better; the paper keeps 0.01 for
#   smooth interpolation).
#
# Box plots as the paper's: box = quartiles, line = median, triangle = mean, whiskers by Tukey's
# rule (1.5 IQR). The paper prints no numbers for these figures, only their ordering, which is
# what we compare against.
#
# Quick mode reads `results/cvae4d_reconstruction.csv`, made from the committed checkpoints by
# `python -m data_prep train-cvae --table` (PCA and both phases on every test cycle of the full
# dataset), and checks that it is current with the checkpoints. Full mode recomputes it here.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import display

from data_prep.sources import REPO_ROOT
from data_prep.train_cvae import ABLATION_TABLE, TABLE, TABLE_MODELS, checkpoint_id
from mocapviz.tasks.cvae4d_eval import boxplot_errors, boxplot_table, error_table
from mocapviz.viz import save_figure
from mocapviz.zoo import find_checkpoint

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 160)

# %%
paths = {n: find_checkpoint(n) for n in TABLE_MODELS}
if QUICK:
    table = pd.read_csv(REPO_ROOT / TABLE, keep_default_na=False)
    current = {m: checkpoint_id(p) for m, p in paths.items()}
    print("the table is current with the committed checkpoints:",
          all(table.loc[table.model == m, "checkpoint"].eq(c).all() for m, c in current.items()))
else:
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    from mocapviz.tasks.cvae4d_eval import PCABaseline, load_checkpoints, reconstruction_errors
    from mocapviz.training.cvae4d import split_indices

    ds = build_dataset(Body4DConfig())
    models = load_checkpoints(ds, paths)
    table = error_table(reconstruction_errors(ds, models, progress=True))
    train_idx, _ = split_indices(ds)
    pca = PCABaseline(ds.chi[train_idx], ds.beta[train_idx], models["cvae4d_phase1"].cfg.latent)
    print(f"PCA: {pca.n_components} components (dim z + dim beta = {pca.requested}); explained variance "
          f"{pca.pca.explained_variance_ratio_.sum():.3f}")
display(table)

# %% [markdown]
# ## Fig. 5: PCA vs phase 1 vs phase 2, per test set

# %%
sets = list(dict.fromkeys(table["test_set"]))
order = {"pca": "PCA", "cvae4d_phase1": "phase 1", "cvae4d_phase2": "phase 2"}
fig, axes = plt.subplots(1, len(sets), figsize=(4.5 * len(sets), 4.2), squeeze=False)
for ax, t in zip(axes[0], sets):
    rows = table[table.test_set == t].set_index("model").loc[list(order)]
    boxplot_table(ax, rows, list(order.values()), f"Fig. 5: '{t}' ({rows.n.iloc[0]} cycles)")
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig05_pca_baseline.png")

# %% [markdown]
# ## Does the paper's ordering hold? (phase 2 < phase 1 < PCA)

# %%
for t in sets:
    m = table[table.test_set == t].set_index("model")["mean"]
    p2, p1, pca_mm = m["cvae4d_phase2"], m["cvae4d_phase1"], m["pca"]
    holds = p2 < p1 < pca_mm
    print(f"'{t}': mean error phase 2 {p2:.1f} mm, phase 1 {p1:.1f} mm, PCA {pca_mm:.1f} mm -> ordering "
          f"{'holds' if holds else 'does NOT hold'}: phase 2 vs phase 1 {100 * (p2 / p1 - 1):+.1f} %, "
          f"phase 1 vs PCA {100 * (p1 / pca_mm - 1):+.1f} %, phase 2 vs PCA {100 * (p2 / pca_mm - 1):+.1f} %")

# %% [markdown]
# ### Why the ordering is not the paper's
#
# The printed means above are the answer; where the ordering fails, these are the causes we can
# name (none was tested separately in this session):
#
# - **Training length**: the paper runs 5000 + 200 epochs on a GPU; the committed models ran
#   400 + 6 epochs on one shared CPU thread (`CVAE_CONFIGS`), and notebook 11's held-out
#   losses were still falling when phase 1 stopped. PCA needs no training: it is the optimum of
#   its linear model on the training cycles.
# - **Width**: hidden widths (48, 128) keep a float16 checkpoint under 3 MiB; the decoder's
#   output is then a linear map of a 48-dimensional layer, fewer directions than PCA's 70
#   components. The paper's layers are not given; `paper_*` configs use (512, 256).
# - **Test sets unlike training**: the held-out source (HDM05 jog and sneak) and the held-out
#   subjects are bodies and motion types with few or no training cycles of their kind; their
#   sets are small (the `n` column), so their means move with a few cycles. The held-out Bandai
#   takes (same actors and skeleton as training) are the set where the models are closest.
# - **Phase 2** is 6 epochs at lr 1e-4 on a 1024-vertex subset: it lowers the means by a few
#   percent (printed above).

# %% [markdown]
# ## Fig. 3 and Fig. 4: latent dimension and KL weight (all test cycles together)
#
# Short phase-1 runs of each setting, compared with each other, not with the committed phase-1
# model. At CPU scale: `python -m data_prep train-cvae --ablations` (the same epochs for every
# model) writes one row per test cycle to `results/cvae4d_ablations.csv`. Where that file is
# absent (this session's CPU went to the two committed phases), the figures come from runs of
# `CVAE_CONFIGS["quick_phase1"]` trained here on the quick dataset: a demonstration of the
# figures on a few dozen training cycles, not a result.

# %%
abl_path = REPO_ROOT / ABLATION_TABLE
if abl_path.exists():
    abl = pd.read_csv(abl_path, keep_default_na=False)
    err = {m: g.error_mm.to_numpy() for m, g in abl.groupby("model")}
    print(f"{ABLATION_TABLE}: {len(err)} models, {abl.epochs.iloc[0]} phase-1 epochs each, "
          f"{abl.cycle.nunique()} test cycles of the full dataset")
else:
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    from data_prep.train_cvae import ABLATIONS
    from mocapviz.tasks.cvae4d_eval import reconstruction_errors, test_sets
    from mocapviz.training.cvae4d import CVAE_CONFIGS, split_indices, train, with_overrides

    qds = build_dataset(Body4DConfig.quick())
    cfg = CVAE_CONFIGS["quick_phase1"]
    quick_models = {n: train(qds, with_overrides(cfg, **kw), progress=False)[0] for n, kw in ABLATIONS.items()}
    quick_errors = reconstruction_errors(qds, quick_models)
    err = {m: np.concatenate([quick_errors[(m, t)] for t in test_sets(qds)]) for m in quick_models}
    print(f"no {ABLATION_TABLE}: quick runs ({cfg.epochs} epochs each) on the quick dataset, "
          f"{len(split_indices(qds)[0])} training and {len(next(iter(err.values())))} test cycles")
fig, (a3, a4) = plt.subplots(1, 2, figsize=(13, 4.2), gridspec_kw=dict(width_ratios=[5, 3]))
latents = {str(z): err[f"cvae4d_z{z}"] for z in (8, 16, 32, 64, 128)}
kls = {"0.001": err["cvae4d_kl0.001"], "0.01": err["cvae4d_z64"], "0.1": err["cvae4d_kl0.1"]}
boxplot_errors(a3, latents, "Fig. 3: latent dimension (KL 0.01, phase 1)", "dim z")
boxplot_errors(a4, kls, "Fig. 4: KL weight (dim z 64, phase 1)", "ω_KL")
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig03_04_ablations.png")
display(pd.DataFrame({"mean_mm": {f"z{k}": v.mean() for k, v in latents.items()}
                      | {f"kl{k}": v.mean() for k, v in kls.items()},
                      "median_mm": {f"z{k}": np.median(v) for k, v in latents.items()}
                      | {f"kl{k}": np.median(v) for k, v in kls.items()}}).round(1).T)
