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
QUICK = True   # quick: read the committed table; full: recompute it (python -m data_prep finetune-table)
FIG_DIR = "../figures"

# %% [markdown]
# # 07 · Unseen skeletons: fine-tuning on a new subject (CCNet §4.6, Table 5)
#
# **What the paper does.** CCNet is trained on many subjects and then meets a skeleton it never
# saw (its subject 7). Given part of that subject's motion (walking, and walking and running),
# the network is fine-tuned, and its one-step predictions on *all* of the subject's other
# motion are scored by the relative pose difference
# $rel_p = \frac1N\sum_n \lVert\hat{\mathbf x}_n - \mathbf x_n\rVert_2 / \lVert\mathbf x_n\rVert_2$
# on the motion-representation vectors (no IK). Table 5 has the full model and two models
# trained on four subjects each (D1: bodies close in size to subject 7, D2: far), each without
# fine-tuning, fine-tuned on walking (W) and on walking and running (W and R).
#
# **What we do** (`python -m data_prep finetune-table`; `mocapviz.tasks.finetune`):
#
# - the novel skeleton is the HDM05 actor `tr`, the dataset's held-out test subject: no clip of
#   `tr` is in training;
# - HDM05 has **no plain walk** for `tr`: its locomotion is `sneak` (our stand-in for W) and
#   `jogLeftCircle...` (`jog`, for R). The two fine-tuning sets are sneak alone and sneak with
#   jog; one sneak clip is held back as the validation clip that picks the fine-tuned checkpoint,
#   so no scored clip chooses the model;
# - the test clips are every clip of `tr` of another motion type, the same for every row;
#   rel_p of the one-step prediction (the mean output, the past being the true frames), on the
#   continuous part of the frame vector in raw units (`mocapviz.metrics.rel_p`);
# - rows: `ccnet_paper` (the paper's network trained for next-frame prediction) without and with
#   each fine-tuning; ERD-4LR (`erd_quick`) without and with, DAE-LSTM (`dae_lstm_quick`)
#   without; the predictors that do nothing (copy the last frame, constant velocity) on the
#   same frames, as the floor any predictor must beat;
# - each fine-tuning row says how many minutes of `tr`'s motion it saw, its steps and its CPU
#   minutes; `rel_p_val` is rel_p on the held-back sneak clip (the kind of motion fine-tuning
#   saw), beside `rel_p` on the test clips (every other kind). CCNet-D1 and CCNet-D2 need two more full trainings and are rows *not run* (the
#   table's `note` says why).

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from data_prep.sources import REPO_ROOT

fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
if not QUICK:
    import subprocess
    import sys
    subprocess.run([sys.executable, "-m", "data_prep", "finetune-table"], cwd=REPO_ROOT, check=True)
ours = pd.read_csv(REPO_ROOT / "results" / "ccnet_table5_finetune.csv")
paper = pd.read_csv(REPO_ROOT / "results" / "paper_ccnet_table5.csv")
run = ours[ours.rel_p.notna()]
print(f"ours: {ours['mode'].iloc[0]} mode, {int(run.n_frames.iloc[0])} predicted frames of "
      f"{int(run.n_clips.iloc[0])} test clips of tr; made by: {ours.command.iloc[0]}")
with pd.option_context("display.max_colwidth", 200):
    print(ours.loc[ours.rel_p.isna(), ["model", "note"]].to_string(index=False))
ours[["model", "fine_tuning", "rel_p", "rel_p_std", "rel_p_val", "ft_clips", "ft_minutes_of_motion", "ft_steps",
      "ft_cpu_minutes", "ft_val_nll_init", "ft_val_nll_best"]]

# %% [markdown]
# Side by side: our rel_p (mean ± std over frames) and the paper's, by model and fine-tuning
# set (our sneak stands for the paper's walking, sneak and jog for walking and running).

# %%
COLUMN = {"none": "none", "walk (sneak)": "walking", "walk and run (sneak, jog)": "walking and running"}
NAME = {"ccnet_paper": "CCNet", "erd_quick": "ERD-4LR", "dae_lstm_quick": "DAE-LSTM",
        "copy_last": "copy last frame", "constant_velocity": "constant velocity"}


def cell(g):
    return g.apply(lambda r: "-" if pd.isna(r.rel_p) else f"{r.rel_p:.4f} ± {r.rel_p_std:.4f}", axis=1)


o = ours.assign(model=ours.model.map(NAME).fillna(ours.model), fine_tuning=ours.fine_tuning.map(COLUMN))
o = o.assign(cell=cell(o)).pivot(index="model", columns="fine_tuning", values="cell")
p = paper.assign(cell=cell(paper)).pivot(index="model", columns="fine_tuning", values="cell")
side = pd.concat({"ours": o, "paper": p}, axis=1).reindex(columns=list(COLUMN.values()), level=1)
side.fillna("")

# %%
base = run[~run.finetuned].set_index("model").rel_p
base_val = run[~run.finetuned].set_index("model").rel_p_val
tuned = run[run.finetuned]
models = [m for m in base.index if m not in ("copy_last", "constant_velocity")]
sets = list(COLUMN)
fig, ax = plt.subplots(figsize=(7.5, 4))
width = 0.8 / len(sets)
for k, s in enumerate(sets):
    by_set = tuned.set_index(["model", "fine_tuning"]).rel_p
    vals = [base[m] if s == "none" else by_set.get((m, s), float("nan")) for m in models]
    ax.bar([i + (k - 1) * width for i in range(len(models))], vals, width, label=f"FT: {s}")
for name, ls in (("copy_last", "--"), ("constant_velocity", ":")):
    ax.axhline(base[name], color="k", ls=ls, lw=1, label=NAME[name])
ax.set_xticks(range(len(models)), [NAME.get(m, m) for m in models])
ax.set(ylabel="rel_p (one step, tr's test clips)",
       title="Table 5: rel_p on the unseen subject tr, with and without fine-tuning")
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(fig_dir / "ccnet_table5_finetune.png", dpi=90)

# %% [markdown]
# Read from the table, not typed: what fine-tuning changed, against the paper's change, and
# where each model stands against doing nothing.

# %%
paper_none = paper[(paper.model == "CCNet") & (paper.fine_tuning == "none")].rel_p.item()
for _, r in tuned.iterrows():
    before = base[r.model]
    line = (f"{NAME.get(r.model, r.model)} fine-tuned on {r.fine_tuning} ({r.ft_minutes_of_motion * 60:.0f} s of tr, "
            f"{int(r.ft_steps)} steps, {r.ft_cpu_minutes:.1f} CPU min): rel_p {before:.4f} -> {r.rel_p:.4f} "
            f"({100 * (r.rel_p - before) / before:+.1f} %); on the held-back sneak clip "
            f"{base_val[r.model]:.4f} -> {r.rel_p_val:.4f} "
            f"({100 * (r.rel_p_val - base_val[r.model]) / base_val[r.model]:+.1f} %)")
    if r.model == "ccnet_paper":
        p_ft = paper[(paper.model == "CCNet") & (paper.fine_tuning == COLUMN[r.fine_tuning])].rel_p.item()
        line += f"; the paper's CCNet: {paper_none:.4f} -> {p_ft:.4f} ({100 * (p_ft - paper_none) / paper_none:+.1f} %)"
    print(line)
best = run.loc[run[run.model.isin(models)].rel_p.idxmin()]
print(f"lowest rel_p of a network: {NAME.get(best.model, best.model)} ({best.fine_tuning}) {best.rel_p:.4f}; "
      f"copy last frame {base['copy_last']:.4f}, constant velocity {base['constant_velocity']:.4f}")
for m in models:
    print(f"{NAME.get(m, m)} without fine-tuning is {'below' if base[m] < base['copy_last'] else 'above'} "
          f"copying the last frame ({base[m]:.4f} vs {base['copy_last']:.4f})")
