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
QUICK = True   # quick: read the committed tables; full: recompute them (python -m data_prep finetune-table, unseen-body)
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
#   each fine-tuning; ERD-4LR (`erd_quick`) and DAE-LSTM (`dae_lstm_quick`) without and with
#   fine-tuning on sneak and jog; the predictors that do nothing (copy the last frame, constant velocity) on the
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

# %% [markdown]
# ## Figs. 9-10: a body no one captured (7b)
#
# **What the paper does** (§4.6). It scales the lower body of its unseen subject 7 by 0.8
# ("7b"), retargets motion capture onto that body to get 120 seed frames, and shows CCNet walking
# and following a trajectory with it (Fig. 10). ERD-4LR and PFNN, it says, "contain large, sharp
# changes between the seed frames and generated frames"; Fig. 9 shows the baselines' feet going
# through the floor on unseen bodies. The paper gives pictures and a video, no numbers.
#
# **What we do** (`python -m data_prep unseen-body`; `mocapviz.tasks.unseen_body`):
#
# - 7b is `tr` (our unseen subject) with the offsets of its hip joints, thighs, shins, feet and
#   toes times 0.8 (`scaled_lower_body`); the seeds are the first 120 frames of tr's locomotion
#   clips long enough for that (its `jogLeftCircle` clips: its sneaks are shorter), scaled to
#   7b's leg length and put on 7b by the library's retargeting and leg IK (`retarget_seed`);
#   7b's own $\mathbf c^s$ goes to the networks, unclamped;
# - each model continues every seed with ten seconds of walking (its own $\mathbf c^d$) and
#   follows two curved paths (the trajectory task's machinery and distances);
# - **the seed-to-generation jump** (`seam_jump`): how fast the body (joint positions relative to
#   the root's point on the ground, so a body that drops or pops up counts) changes over the
#   first three frames from the last seed frame, as a multiple of its median speed over the
#   seed's last second. A real clip cut anywhere scores about 1 (row `real_clip`: the seed clip
#   cut at every frame); a freeze scores 0 (row `copy_last`); `jump_pose` leaves the body's
#   height out;
# - the feet (Fig. 9): the lowest joint of the generated frames against the seed's floor
#   (`penetration_cm`, its mean depth under it, over the whole run and, `penetration_1s_cm`, over
#   the first second; `foot_height_cm`, its median height over it);
# - body `tr` (its own legs) is the control: the same seeds without the scaling. Pipeline
#   "generate command" is `ccnet_generate` through the generate command's
#   `generate_from_seed` (the seed scaled into the training bodies' sizes, the feet held on the
#   seed's floor) instead of the seed straight into the network.

# %%
from mocapviz.tasks import unseen_body as ub

if not QUICK:
    import subprocess
    import sys
    subprocess.run([sys.executable, "-m", "data_prep", "unseen-body"], cwd=REPO_ROOT, check=True)
unseen = pd.read_csv(REPO_ROOT / "results" / "ccnet_unseen_body.csv")
print(f"ours: {unseen['mode'].iloc[0]} mode, {int(unseen.n_seeds.iloc[0])} seeds "
      f"({unseen.seeds.iloc[0]}); made by: {unseen.command.iloc[0]}")
SHOW = ["body", "task", "model", "pipeline", "jump", "jump_pose", "penetration_cm", "penetration_1s_cm",
        "foot_height_cm", "distance_cm", "distance_std_cm", "covered", "timed_cm"]
unseen[SHOW].round(2)

# %% [markdown]
# The paper's claims beside ours, read from the table (`seam_verdict` and `ground_verdict`
# call a jump sharp and feet through the floor or floating past thresholds printed below).

# %%
NETS = ["ccnet_paper", "ccnet_generate", "erd_quick", "pfnn_quick"]
walks = unseen[(unseen.task == "walk")].set_index(["body", "model", "pipeline"])
follows = unseen[(unseen.task == "follow")].set_index(["body", "model"])


print(f"sharp: a jump over {ub.SHARP:g}x the real clip's; through the floor / floating: feet over "
      f"{ub.FLOOR_CM:g} cm under it on average / a median lowest joint over {ub.FLOOR_CM:g} cm above it")
print('paper: ERD-4LR and PFNN show "large, sharp changes between the seed frames and generated frames" '
      "for 7b; CCNet generalises to it (Fig. 10); baselines' feet go through the floor (Fig. 9)")
for body in walks.index.unique("body"):
    real = walks.loc[(body, "real_clip", "-")]
    print(f"\nours, body {body}: a real clip cut anywhere scores jump {real.jump:.2f}")
    for m in NETS:
        w, f = walks.loc[(body, m, "network")], follows.loc[(body, m)]
        print(f"  {m:15s} walk: jump {w.jump:5.1f} ({ub.seam_verdict(w.jump, real.jump)}; pose alone {w.jump_pose:.1f}); feet in the first "
              f"second {w.penetration_1s_cm:.1f} cm under the floor on average, over the run "
              f"{ub.ground_verdict(w.penetration_cm, w.foot_height_cm)} ({w.penetration_cm:.1f} cm under, median "
              f"{w.foot_height_cm:+.1f} cm); follow: {f.distance_cm:.0f} ± "
              f"{f.distance_std_cm:.0f} cm, covered {f.covered:.2f}, {f.timed_cm:.0f} cm behind the target point")
    if (body, "ccnet_generate", "generate command") in walks.index:
        g = walks.loc[(body, "ccnet_generate", "generate command")]
        print(f"  ccnet_generate through the generate command: jump {g.jump:.1f}, feet over the run "
              f"{ub.ground_verdict(g.penetration_cm, g.foot_height_cm)} ({g.penetration_cm:.1f} cm under)")
    s = follows.loc[(body, "stand_still")]
    print(f"  standing still: {s.distance_cm:.0f} cm from the path (it starts there), covered {s.covered:.2f}, "
          f"{s.timed_cm:.0f} cm behind the target point")

# %% [markdown]
# Film strips (Figs. 9-10 stand-in): the first seed's last frames (grey) and the first generated
# frames (coloured) of each model, from the side in the body's own heading, heights above the
# seed's floor (dashed), joints more than 2 cm under it in red; on 7b, then on tr's own body.
# Generated again here for one seed and one second (quick mode: the quick dataset, whose tr clips
# are the same).

# %%
import torch

from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from data_prep.zoo import load
from mocapviz.tasks import trajectory_following as tf
from mocapviz.viz.figures import show_figure

torch.set_num_threads(1)
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
seed_row = ub.seed_rows(ds)[:1]
nets = {m: load(m, progress=False)[:2] for m in NETS}
bodies = {"7b": ub.body_dataset(ds, seed_row), "tr": ub.body_dataset(ds, seed_row, 1.0)}
n = ub.SEED_FRAMES
for name, bds in bodies.items():
    strips = {f"{m} on {name}": ub.walk_motions(model, norm, bds, [0], 1.0)[0] for m, (model, norm) in nets.items()}
    show_figure(ub.seam_strip(strips, n, path=fig_dir / f"ccnet_unseen_body_strip_{name}.png"))
    for label, m in strips.items():  # the root's height across the seam: does the network read the body?
        root = m.root_positions[:, 1]
        print(f"{label}: root {root[n - 1]:.2f} m at the last seed frame, {root[n]:.2f} m at the first "
              f"generated one, {root[n + 30]:.2f} m 0.5 s on")

# %% [markdown]
# Fig. 10 stand-in: trajectory following on 7b (the S-curve, the same seed), each model's root
# path over the target.

# %%
speeds = tf.type_speeds(ds)
runs = {m: tf.follow(model, norm, bodies["7b"], [0], "s_curve", speeds, model_name=m)
        for m, (model, norm) in nets.items()}
show_figure(ub.following_top_view(runs, title=f"{ds.clips['clip'][seed_row[0]]} on 7b",
                                  path=fig_dir / "ccnet_unseen_body_fig10.png"))
