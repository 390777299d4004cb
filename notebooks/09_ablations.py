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
QUICK = True   # quick: read the committed table; full: recompute it (python -m data_prep apps-tables --only seed-length)
FIG_DIR = "../figures"

# %% [markdown]
# # 09 · Hyper-parameters and ablations (CCNet §4.8, Table 7; Figs. 11-12 not yet)
#
# **Table 7: the length of the seed.** How well does a model predict the next frame from a seed
# of 1, 5, 10, 30, 60 or 120 frames? For each length $L$ the model sees only the $L$ frames before
# the predicted one (a causal CCNet its zero padding before them, an LSTM its empty state), and
# the prediction is scored by the paper's relative pose difference
# $rel_p = \frac1N\sum_n \lVert\hat{\mathbf x}_n - \mathbf x_n\rVert / \lVert\mathbf x_n\rVert$
# on the frame vectors (`mocapviz.metrics.rel_p`; the continuous part of $\mathbf x$ in raw
# units: radians, metres, rad/s, m/s), over the same predicted frames of the test clips for
# every length and model (`mocapviz.tasks.seed_length`). The rows that do nothing (copy the last
# frame, constant velocity) answer the same question with the same frames.
#
# The ablations of Figs. 11-12 (receptive field, window length, without rotations, without the
# smoothness loss, without $\mathbf c^s$, LSTMs in place of the SRBs) are not run yet: the
# README's paper map says so.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from data_prep.sources import REPO_ROOT

fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
if QUICK:
    ours = pd.read_csv(REPO_ROOT / "results" / "ccnet_table7_seed_length.csv")
else:
    import subprocess
    import sys
    subprocess.run([sys.executable, "-m", "data_prep", "apps-tables", "--only", "seed-length"], cwd=REPO_ROOT, check=True)
    ours = pd.read_csv(REPO_ROOT / "results" / "ccnet_table7_seed_length.csv")
paper = pd.read_csv(REPO_ROOT / "results" / "paper_ccnet_table7.csv")
print(f"ours: {ours['mode'].iloc[0]} mode, {ours.n.iloc[0]} predicted frames per cell; made by: {ours.command.iloc[0]}")
table = ours.pivot_table(index="seed_frames", columns="model", values="rel_p")
table.join(paper.pivot_table(index="seed_frames", columns="model", values="rel_p").add_prefix("paper "))

# %%
fig, ax = plt.subplots(figsize=(7, 4))
for model in table.columns:
    ax.plot(table.index, table[model], marker="o", label=model)
for model, g in paper.groupby("model"):
    ax.plot(g.seed_frames, g.rel_p, ls="--", marker="x", label=f"paper {model}")
ax.set(xscale="log", xlabel="seed frames", ylabel="rel_p", title="Table 7: one-step rel_p against the seed's length")
ax.legend(fontsize=7, ncol=2)
fig.tight_layout()
fig.savefig(fig_dir / "ccnet_table7_seed_length.png", dpi=90)

# %% [markdown]
# Read from the table, not typed: which models beat copying the last frame at each length, and
# how much a model gains from a longer seed.

# %%
for model in table.columns:
    if model in ("copy_last", "constant_velocity"):
        continue
    beats = [int(L) for L in table.index if table.loc[L, model] < table.loc[L, "copy_last"]]
    print(f"{model}: rel_p {table[model].iloc[0]:.3f} after 1 frame, {table[model].iloc[-1]:.3f} after "
          f"{int(table.index[-1])}; below copying the last frame at seed lengths {beats or 'none'}")
