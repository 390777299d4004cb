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
#   of the full dataset (held-out Bandai takes on Bandai's body and on held-out bodies; the real
#   cycles of the held-out subjects HDM05 tr, CMU 35 and 09);
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
import pandas as pd
import torch
from IPython.display import display

from data_prep.sources import REPO_ROOT
from data_prep.train_cvae import ABLATION_TABLE, TABLE, TABLE_MODELS, checkpoint_id
from mocapviz.tasks.cvae4d_eval import (boxplot_table, error_table, gaps_beyond_spread, ordering_steps,
                                        paper_ordering_holds)
from mocapviz.training.cvae4d import load_cvae
from mocapviz.viz import save_figure
from mocapviz.zoo import cvae4d_epochs, find_checkpoint

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
    if {"cvae4d_phase1_seed1", "cvae4d_phase2_seed1"} <= set(m.index):  # a second training seed: the spread
        q1, q2 = m["cvae4d_phase1_seed1"], m["cvae4d_phase2_seed1"]
        g = gaps_beyond_spread((p1, q1), (p2, q2), pca_mm)
        print(f"    second seed: phase 2 {q2:.1f}, phase 1 {q1:.1f} mm; run-to-run spread {g['spread']:.1f} mm; worst-case "
              f"gaps phase 1 - phase 2 {g['gap_phase1_phase2']:.1f} mm, PCA - phase 1 {g['gap_pca_phase1']:.1f} mm -> "
              f"{'both larger than the spread' if g['holds'] else 'NOT both larger than the spread'}")

# %% [markdown]
# ### How much each encoder loses: codes fitted per cycle
#
# The same decoders with their input code fitted to each test cycle's mesh (Adam on z, or on
# PCA's codes, the body's β fixed at the truth; `mocapviz.tasks.cvae4d_eval.fitted_errors`), on
# a seeded draw of at most 40 cycles per test set. `unfitted_mean` is the same model's error on
# those cycles with its own code (the encoder's μ, PCA's projection). The gap is what the
# encoder (or PCA's projection, optimal in χ but not in vertices) leaves on the table; the
# fitted error is what the decoder can express. Both modes read the committed table (the fits
# take minutes: `python -m data_prep train-cvae --table`).

# %%
from mocapviz.tasks.cvae4d_eval import FIT_SUFFIX

committed_table = pd.read_csv(REPO_ROOT / TABLE, keep_default_na=False)
fits = committed_table[committed_table.model.str.endswith(FIT_SUFFIX)]
for t in sets:
    for r in fits[fits.test_set == t].itertuples():
        base = r.model[:-len(FIT_SUFFIX)]
        print(f"'{t}' ({r.n} cycles) {base:14s}: own code {float(r.unfitted_mean):6.1f} mm -> fitted {r.mean:6.1f} mm "
              f"({100 * (r.mean / float(r.unfitted_mean) - 1):+.0f} %)")

# %% [markdown]
# ### Where it holds and where it does not
#
# The printed means above are the answer. The held-out takes and the held-out bodies (Bandai
# takes the model never saw, on Bandai's body or on a body it never saw; about 400 cycles each)
# are the sets large enough to tell; the `_seed1` rows of the table are a second training seed,
# the run-to-run spread to compare the gaps with. The held-out subjects are all the real cycles
# the data hold of three unseen performers (the `n` column): HDM05 `tr`'s jogs and two CMU
# walkers, motion unlike the Bandai takes that make most of training; their means move with a
# single cycle. The committed models ran within a CPU budget (`CVAE_CONFIGS`), not the paper's
# 5000 + 200 epochs, and notebook 11's validation losses were still falling when phase 1
# stopped.
#
# The ablation table below was made on the same dataset split as these models (body4d v3) with
# their widths, in short phase-1 runs whose draws are balanced by body only (the committed models
# also balance the motion types within a body: notebook 11 prints `balance_types`).

# %% [markdown]
# ## Fig. 3 and Fig. 4: latent dimension and KL weight
#
# Seven short phase-1 runs on the full dataset, identical but for the ablated value: latent
# 8 / 16 / 32 / 128 at KL 0.01, KL 0.001 / 0.1 at latent 64, and latent 64 at KL 0.01, the
# reference of both figures, trained the same short way (so its boxes are not the committed
# `cvae4d_phase1`'s, which trained longer). `python -m data_prep train-cvae --ablations` trains
# them on one CPU thread (their checkpoints stay in `cache/runs/abl_*`, uncommitted) and writes
# `results/cvae4d_ablations.csv`: per ablation, value and test set the Tukey summary of the
# per-cycle mean vertex errors (mm), and "all", every test cycle together. Both modes read that
# table; re-making it is that command, not a notebook step. The runs' epochs and the command are
# printed from the table below.
#
# **The paper's reading** (§4.3, Figs. 3-4, on AMASS): "the bigger the latent space dimension,
# the smaller the error", falling quickly up to 64 and stagnating after, hence 64; "the smaller
# $\omega_{KL}$, the smaller the reconstruction error", but at 0.001 interpolations are no longer
# plausible, hence 0.01 as the trade-off. The paper prints no numbers for these figures, so we
# compare orderings. Its models were trained through both phases, ours through phase 1 only.

# %%
abl = pd.read_csv(REPO_ROOT / ABLATION_TABLE, keep_default_na=False)
epochs, n_train = int(abl.epochs.iloc[0]), load_cvae(paths["cvae4d_phase1"])[1]["dataset"]["n_train"]
n_test = int(abl.loc[abl.test_set == "all", "n"].iloc[0])
print(f"{ABLATION_TABLE}: {abl.model.nunique()} runs of {epochs} phase-1 epochs each, made by "
      f"`{abl.command.iloc[0]}`; {n_train} training cycles, {n_test} test cycles; dataset {abl.dataset.iloc[0]}")
figs = {"latent": ("Fig. 3: latent dimension (KL 0.01)", "dim z"),
        "kl_weight": ("Fig. 4: KL weight (dim z 64)", "ω_KL")}
abl_sets = ["all", *sorted(set(abl.test_set) - {"all"})]  # the test sets of the build it was made on
fig, axes = plt.subplots(2, len(abl_sets), figsize=(4.2 * len(abl_sets), 8.4), squeeze=False)
for row, (ablation, (title, xlabel)) in zip(axes, figs.items()):
    for ax, t in zip(row, abl_sets):
        rows = abl[(abl.ablation == ablation) & (abl.test_set == t)].sort_values("value")
        boxplot_table(ax, rows, [f"{v:g}" for v in rows.value], f"{title}\n'{t}' ({rows.n.iloc[0]} cycles)")
        ax.set_xlabel(xlabel)
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig03_04_ablations.png")
display(abl.pivot_table(index=["ablation", "value"], columns="test_set", values=["median", "mean"]).round(1))

# %% [markdown]
# ### Does the paper's ordering hold?
#
# Read on the medians (the boxes' lines) over all test cycles, with the means beside: Fig. 3
# holds if every step from 8 up to 64 lowers the error (past 64 the paper sees it stagnate, so
# 64 -> 128 is printed, not judged); Fig. 4 holds if every larger KL weight raises it. The KL
# weight's effect also depends on the loss it is weighed against: the paper notes its 0.01 is tied
# to vertex errors in metres; ours are weighed against phase 1's χ losses under GradNorm weights.

# %%
PAPER_CYCLES, PAPER_EPOCHS = 13121, 5000  # paper §4.1-4.2: AMASS training cycles, phase-1 epochs


def ordering_sentence(ablation, t="all"):
    rows = abl[(abl.ablation == ablation) & (abl.test_set == t)]
    by = {stat: ordering_steps(rows, stat) for stat in ("median", "mean")}
    values = " -> ".join(f"{v:g}: {m:.1f} mm" for v, m in zip(rows.sort_values("value").value,
                                                              rows.sort_values("value")["median"]))
    holds = {stat: paper_ordering_holds(st, ablation) for stat, st in by.items()}
    steps = ", ".join(f"{lo:g} -> {hi:g} {c:+.1f} %" for lo, hi, c in by["median"][["low", "high", "change_pct"]].values)
    expected = "falling up to 64" if ablation == "latent" else "rising with the weight"
    return (f"{figs[ablation][0]}, '{t}' ({rows.n.iloc[0]} cycles), medians {values} ({steps}): the paper's "
            f"ordering ({expected}) {'holds' if holds['median'] else 'does NOT hold'} on the medians, "
            f"{'holds' if holds['mean'] else 'does not hold'} on the means."), holds["median"], rows


for ablation in figs:
    sentence, holds, rows = ordering_sentence(ablation)
    print(sentence)
    if not holds:
        spread = rows["median"].max() - rows["median"].min()
        print(f"  Why not, likely (not tested one by one): short runs, {epochs} phase-1 epochs against the paper's "
              f"{PAPER_EPOCHS:,} (the committed run's held-out loss was still falling after "
              f"{cvae4d_epochs('cvae4d_phase1')[0]} epochs, notebook 11), "
              f"so a setting that learns more slowly is judged early; {n_train} training cycles against the "
              f"paper's {PAPER_CYCLES:,}; and the medians differ by {spread:.1f} mm at most, against boxes "
              f"(IQR) {(rows.q3 - rows.q1).min():.1f}-{(rows.q3 - rows.q1).max():.1f} mm high.")
    if ablation == "latent":
        last = ordering_steps(rows).iloc[-1]
        print(f"  64 -> 128 (the paper: stagnates): {last.change_pct:+.1f} % on the median.")
    for t in abl_sets[1:]:
        print("   ", ordering_sentence(ablation, t)[0])
