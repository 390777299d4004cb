# ---
# jupyter:
#   jupytext:
#     cell_metadata_filter: tags,-all
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
QUICK = True  # quick: the quick dataset's cycles (seconds to build); full: every cycle of the full dataset
FIG_DIR = "../figures"
N_PATH = 21  # interpolation steps measured along each path
N_SHOW = 5  # of which rendered (evenly spaced, both ends included)

# %% [markdown]
# # 13 · The latent motion space: structure and interpolation (4D motion paper Fig. 1 right, §4.5, Fig. 6)
#
# Every gait cycle is one latent vector. Here we look at that space with the committed CVAE:
#
# 1. **Structure** (Fig. 1, top right): the latent means $\mu$ of every cycle (z = μ, no
#    sampling) reduced to two dimensions by PCA (scikit-learn), coloured by motion type and
#    marked by split (training / held out). How clustered the types are is also measured in the
#    full 64-D space: the share of cycles whose nearest other cycle has the same type.
# 2. **Interpolation** (Fig. 6): $z$ and $\beta$ moved linearly from a start cycle to a target
#    cycle and decoded; each cycle rendered as a strip of frames coloured dark to light in time,
#    the true start and target around the interpolated ones. Along each path we measure, from
#    the decoded $\chi$ (`mocapviz.tasks.cvae4d_latent.cycle_measurements`):
#    - **run ↔ walk** (temporal axis): the decoded duration (last timestamp of Φ) and whether it
#      changes monotonically;
#    - **walk back ↔ walk forward** (global displacement): the root's displacement over the cycle
#      (signed along the first heading, and its ground-plane length, the "step"), the smallest
#      step on the path, and how many training cycles make a step that small;
#    - **left turn ↔ right turn** (global pose): the root's heading change over the cycle
#      (positive = left);
#    - an **arm** interpolation (the paper's walk ↔ walk carrying an object on the head) if the
#      data hold one.
#
# Start and target are the *medoids* of their type among the training cycles: the cycle whose
# $\mu$ is closest to the type's mean $\mu$ (no hand picking). A medoid is typical in the latent
# space, not the most extreme example (a medoid right turn can turn only a few degrees). The
# "step" is the root's displacement over the whole gait cycle (two steps). The training cycles a
# step is compared with are those of the build shown: quick mode's small build, or, in full mode,
# the model's whole training set.
#
# **What the paper shows.** Fig. 1 (top right) plots AMASS cycles in a 2-D linear projection of
# the motion space: walks, runs and other locomotion types form separate clusters. Fig. 6
# renders four interpolations: run → walk, whose duration changes monotonically along the path;
# walk backward → forward, whose intermediate cycle is "a really small step", smaller than any
# in the training set; left turn → right turn, changing gradually; walk → walk carrying an object
# on the head, raising the arms gradually. The paper gives no numbers for these figures.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep.body4d_dataset import Body4DConfig, build_dataset
from mocapviz.bodies import body_model
from mocapviz.bodies.torch_mesh import ChiMesher
from mocapviz.tasks.cvae4d_eval import on_scale
from mocapviz.tasks.cvae4d_latent import (clustering_scores, cycle_measurements, interpolate, is_monotonic,
                                          latent_means, latent_pca, neighbour_agreement, path_comparison, pca_codes,
                                          smallest_step, type_medoid)
from mocapviz.training.cvae4d import data_fingerprint, split_indices
from mocapviz.viz import cycle_strips, save_figure, set_notebook_backend
from mocapviz.zoo import cvae4d_epochs, load_cvae4d

torch.set_num_threads(1)
set_notebook_backend(QUICK)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 160)

# %% [markdown]
# ## Data and model
#
# The committed CVAE (phase 2 when it is committed, else phase 1), trained on the full dataset.
# Quick mode embeds the quick build's cycles (notebook 10's small build; its held-out cycles are
# held out by the same rules as the full build's, so the model never saw them); full mode embeds
# every cycle of the full build, the model's own training set. Each build scales translations by
# its own training cycles, so the cycles are first put on the checkpoint's scale (`on_scale`).


# %%
MODEL = "cvae4d_phase2"
model, meta = load_cvae4d(MODEL)
ds = build_dataset(Body4DConfig.quick() if QUICK else Body4DConfig())
print(f"model {MODEL}: latent {model.cfg.latent}, trained on {meta['dataset']['n_train']} training cycles "
      f"(dataset {meta['dataset']['hash']}); this dataset is its training data: "
      f"{data_fingerprint(ds) == meta['dataset']['fingerprint']}")
ds = on_scale(ds, meta["dataset"]["gamma_scale"])
cycles = ds.cycles.reset_index(drop=True)
n_kept = len(ds.meta["chi_joints"])
train_idx, held_idx = split_indices(ds)
types = cycles["type"].to_numpy()
print(f"{len(ds)} cycles ({len(train_idx)} training, {len(ds) - len(train_idx)} held out); per type:",
      cycles["type"].value_counts().to_dict())

# %% [markdown]
# ## Fig. 1 (right): the latent means in two dimensions

# %%
mu = latent_means(model, ds.chi)
xy, ratio, _ = latent_pca(mu)
fig, (ax, ax_s) = plt.subplots(1, 2, figsize=(16, 6.5))
colors = dict(zip(sorted(set(types)), plt.cm.tab10.colors))
for t in sorted(set(types)):
    for split, marker, size in (("train", "o", 14), ("test", "x", 30)):
        sel = (types == t) & (cycles["split"].to_numpy() == split)
        if sel.any():
            ax.scatter(xy[sel, 0], xy[sel, 1], s=size, marker=marker, color=colors[t], alpha=0.7,
                       label=f"{t} ({split}, {sel.sum()})")
ax.set(xlabel=f"PC 1 ({100 * ratio[0]:.1f} % of the variance)", ylabel=f"PC 2 ({100 * ratio[1]:.1f} %)",
       title=f"latent means of {len(ds)} cycles ({MODEL}); o training, x held out")
ax.legend(fontsize=8, ncol=2)
subjects = cycles["subject"].to_numpy()
for k, subj in enumerate(sorted(set(subjects))):
    sel = subjects == subj
    ax_s.scatter(xy[sel, 0], xy[sel, 1], s=10, color=plt.cm.tab20(k % 20), alpha=0.6, label=f"{subj} ({sel.sum()})")
ax_s.set(xlabel="PC 1", ylabel="PC 2", title="the same points coloured by subject")
ax_s.legend(fontsize=7, ncol=2)
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig01_latent_pca.png")
print(f"explained variance of the two components: {ratio[0]:.3f} + {ratio[1]:.3f} = {ratio.sum():.3f}")
print(f"nearest other cycle in the {mu.shape[1]}-D latent space has the same type for "
      f"{100 * neighbour_agreement(mu, types):.1f} % of the cycles "
      f"(by chance, i.e. drawing a type by its share: {100 * (cycles['type'].value_counts(normalize=True) ** 2).sum():.1f} %)")
print(f"... the same subject: {100 * neighbour_agreement(mu, subjects):.1f} % "
      f"(by chance: {100 * (cycles['subject'].value_counts(normalize=True) ** 2).sum():.1f} %)")
display(pd.DataFrame(xy, columns=["pc1", "pc2"]).assign(type=types).groupby("type").agg(["mean", "std"]).round(2))

# %% [markdown]
# ### Is the latent space more clustered than the data themselves?
#
# Chance is a bar no representation fails. The same nearest-neighbour share is computed on raw χ
# (each cycle flattened; no training at all) and on PCA codes of χ as wide as the latent (PCA
# fitted on the training cycles of this build; at most their count − 1 components). The latent
# space earns the word "clustered" only where it beats these; a lower latent score is a failure
# of this check.

# %%
scores = pd.DataFrame({label: clustering_scores(mu, ds.chi, values, train_idx)
                       for label, values in (("type", types), ("subject", subjects))}).T
display(scores.round(3))
print(f"same type as the nearest other cycle: latent {100 * scores.loc['type', 'latent']:.1f} %, raw chi "
      f"{100 * scores.loc['type', 'raw_chi']:.1f} %, PCA-{int(scores.loc['type', 'pca_components'])} "
      f"{100 * scores.loc['type', 'pca']:.1f} %, chance {100 * scores.loc['type', 'chance']:.1f} %; the latent beats "
      f"raw chi: {scores.loc['type', 'latent'] > scores.loc['type', 'raw_chi']}, beats PCA: "
      f"{scores.loc['type', 'latent'] > scores.loc['type', 'pca']}")

# %% [markdown]
# ## Fig. 6: interpolations
#
# Each path: `N_PATH` steps measured (table), `N_SHOW` of them rendered between the true start
# (top) and the true target (bottom). Meshes on the interpolated β, the hips placed at the
# interpolated first-frame height. Measurements of the true start and target are printed too.

# %%
body = body_model()
mesher = ChiMesher(body, ds.gamma_scale)
true_measures = cycle_measurements(ds.chi, n_kept, ds.gamma_scale)
train_measures = true_measures.iloc[train_idx]


@torch.no_grad()
def mesh(chi, beta, hips_y):
    """Vertices (N, V, 3) of one cycle, its first hips position at (0, hips_y, 0)."""
    return mesher(torch.as_tensor(chi)[None], torch.as_tensor(beta)[None],
                  root0=torch.tensor([[0.0, float(hips_y), 0.0]]))[0].numpy()


def run_path(start_type, target_type, tag):
    """Interpolate between the two types' training medoids; measure, render, return the path table."""
    i0 = type_medoid(mu, train_idx[types[train_idx] == start_type])
    i1 = type_medoid(mu, train_idx[types[train_idx] == target_type])
    alphas, chi, beta = interpolate(model, mu[i0], ds.beta[i0], mu[i1], ds.beta[i1], N_PATH)
    path = cycle_measurements(chi, n_kept, ds.gamma_scale)
    path.insert(0, "alpha", alphas)
    ends = true_measures.iloc[[i0, i1]].assign(cycle=[f"start {start_type}", f"target {target_type}"],
                                               subject=cycles["subject"].iloc[[i0, i1]].to_numpy(),
                                               style=cycles["style"].iloc[[i0, i1]].to_numpy())
    display(ends.set_index("cycle").round(3))
    display(path.round(3).set_index("alpha"))
    show = np.linspace(0, N_PATH - 1, N_SHOW).round().astype(int)
    y0 = cycles["root0_y"].to_numpy()[[i0, i1]]
    meshes = [mesh(ds.chi[i0], ds.beta[i0], y0[0])]
    labels = [f"start (truth): {start_type} | {cycles['subject'].iloc[i0]}"]
    for k in show:
        a = alphas[k]
        meshes.append(mesh(chi[k], beta[k], (1 - a) * y0[0] + a * y0[1]))
        r = path.iloc[k]
        labels.append(f"alpha {a:.2f}: {r.duration_s:.2f} s, {r.forward_m:+.2f} m forward, turn {r.turn_deg:+.0f} deg")
    meshes.append(mesh(ds.chi[i1], ds.beta[i1], y0[1]))
    labels.append(f"target (truth): {target_type} | {cycles['subject'].iloc[i1]}")
    png = fig_dir / f"cvae4d_fig06_{tag}.png"
    cycle_strips(body, meshes, labels, path=png)
    display(Image(filename=str(png)))
    return path


# %% [markdown]
# ### Run ↔ walk (temporal axis)

# %%
run_walk = run_path("run", "walk", "run_walk")
d = run_walk["duration_s"]
print(f"decoded duration from {d.iloc[0]:.3f} s (alpha 0, run) to {d.iloc[-1]:.3f} s (alpha 1, walk); "
      f"monotonic along the {N_PATH} steps: {is_monotonic(d)}")

# %% [markdown]
# ### Walk back ↔ walk forward (global displacement)

# %%
back_fwd = run_path("walk_back", "walk", "walkback_walk")
s = smallest_step(back_fwd["step_m"], train_measures["step_m"])
print(f"signed displacement along the first heading from {back_fwd.forward_m.iloc[0]:+.3f} m to "
      f"{back_fwd.forward_m.iloc[-1]:+.3f} m; monotonic: {is_monotonic(back_fwd.forward_m)}")
print(f"smallest step on the path: {s['step_m']:.3f} m at alpha {back_fwd.alpha.iloc[s['index']]:.2f}; training "
      f"cycles of this build with a step at most that long: {s['n_train_at_most']} of {s['n_train']} (their "
      f"smallest step is {s['train_min_m']:.3f} m){'; quick mode: the quick build only, full mode compares with every training cycle' if QUICK else ''}")

# %% [markdown]
# ### Left turn ↔ right turn (global pose)

# %%
turns = run_path("turn_left", "turn_right", "turnleft_turnright")
print(f"heading change over the cycle from {turns.turn_deg.iloc[0]:+.1f} deg (alpha 0) to {turns.turn_deg.iloc[-1]:+.1f} "
      f"deg (alpha 1); monotonic: {is_monotonic(turns.turn_deg)}; sign change (left to right) on the path: "
      f"{bool((turns.turn_deg.max() > 0) and (turns.turn_deg.min() < 0))}")
tm = true_measures.assign(type=types).groupby("type")["turn_deg"].describe()[["count", "mean", "min", "max"]]
display(tm.round(1))  # the data's own heading change per type: left turns positive, right turns negative

# %% [markdown]
# ### The same checks on baselines that could fail them
#
# Each path's checks (monotonic duration, displacement and turn; the smallest step against the
# training steps) are computed on three other paths between the same two cycles: the straight
# line in raw χ, the straight line between their PCA codes (the PCA above, decoded by it), and a
# random walk in the latent space from the start, with as many steps as the latent path, each as
# long as one of its steps (decoded by the model). A check the raw line also passes says nothing
# about the latent space; one the random walk passes says nothing at all. `nearest_train_rms`:
# how far the path's inner cycles lie from their nearest training cycle (RMS over χ's numbers,
# mean over the path): a latent path that stays on the data should be nearer than the raw line.

# %%
_, chi_pca = pca_codes(ds.chi, train_idx, mu.shape[1])
baselines = {}
for start_type, target_type in (("run", "walk"), ("walk_back", "walk"), ("turn_left", "turn_right")):
    i0 = type_medoid(mu, train_idx[types[train_idx] == start_type])
    i1 = type_medoid(mu, train_idx[types[train_idx] == target_type])
    baselines[f"{start_type} -> {target_type}"] = path_comparison(model, ds.chi, ds.beta, mu, i0, i1, train_idx, N_PATH,
                                                                   n_kept, ds.gamma_scale, chi_pca)
baselines = pd.concat(baselines, names=["interpolation"])
display(baselines.round(3))
wb = baselines.loc["walk_back -> walk"]
print(f"walk back -> forward passes a step smaller than every training step: latent {wb.loc['latent', 'step_below_training']}, "
      f"raw chi line {wb.loc['raw_chi', 'step_below_training']}, PCA line {wb.loc['pca', 'step_below_training']}, "
      f"random walk {wb.loc['random_walk', 'step_below_training']}")
near = baselines["nearest_train_rms"].unstack()
print("inner cycles nearer the training cycles on the latent path than on the raw chi line:",
      (near["latent"] < near["raw_chi"]).to_dict())

# %% [markdown]
# ### Arm motion
#
# The paper's fourth interpolation is walk → walk carrying an object on the head, an arm change
# on the same gait. Our body4d dataset holds cyclic locomotion only (its motion types below);
# Bandai's hand actions and gestures are not cyclic gaits and are not in it, and its walk styles
# (below) are manners of walking (moods, ages, characters), none an arm task such as carrying.
# So the data hold no arm interpolation of the paper's kind, and there is none here.

# %%
print("motion types in the data:", sorted(set(types)))
print("walk styles:", sorted(s for s in set(cycles.loc[cycles["type"] == "walk", "style"]) if s))

# %% [markdown]
# ## Ours beside the paper
#
# The paper shows each property as a picture; ours are measured (the printed lines above), so
# the comparison is: does each path do what the paper describes? Run → walk: the paper's
# duration changes monotonically; walk back → forward: the paper's path passes through a step
# smaller than any training step; left → right turn: the paper's heading changes gradually from
# left to right. The checks below are computed from the tables above, with, for the small step
# and the clustering, whether the baselines above pass them too.

# %%
print(f"run -> walk duration monotonic: {is_monotonic(run_walk.duration_s)} (paper: yes)")
print(f"walk back -> forward passes a step smaller than every training step: "
      f"{s['n_train_at_most'] == 0} (paper: yes); smallest {s['step_m']:.3f} m vs training minimum "
      f"{s['train_min_m']:.3f} m")
print(f"left -> right turn heading change monotonic from positive to negative: "
      f"{is_monotonic(turns.turn_deg) and turns.turn_deg.iloc[0] > 0 > turns.turn_deg.iloc[-1]} (paper: yes)")
print(f"... the same small-step check on the straight line in raw chi: {wb.loc['raw_chi', 'step_below_training']}; "
      f"types clustered more in the latent space than in raw chi: {scores.loc['type', 'latent'] > scores.loc['type', 'raw_chi']}"
      f", than in PCA codes of its size: {scores.loc['type', 'latent'] > scores.loc['type', 'pca']}")

# %% [markdown]
# **The gap and its cause.** The paper trains on 13,121 AMASS cycles of many subjects and
# locomotion types (5,000 + 200 epochs on a GPU, SMPL bodies); ours on the training cycles printed
# below, nearly all from Bandai's three actors (a single skeleton), fitted to **anny** instead of
# SMPL (β has anny's phenotype parameters, not SMPL's 8 shape coefficients), for the CPU epochs
# printed below. So our
# latent space holds fewer subjects, fewer types (no side steps, no carrying, only a few jogs)
# and less training. The 2-D PCA keeps only the share of the 64-D variance printed above: types
# that overlap in the plane can still be apart in the full space (the nearest-neighbour share
# says how far). The right panel shows what else the plane separates: the performer (each
# Bandai actor walks and runs in his own way), which the paper's many-subject AMASS data spread
# more thinly; turning walks lie among the walks, as they are walks. And the interpolation's start and target come from the same dataset the model
# was trained on, as in the paper (which picks them by hand from AMASS).

# %%
phases = dict.fromkeys(["cvae4d_phase1", MODEL])  # the phases behind the model shown
epochs = " + ".join(f"{kept} (of {run} run)" for run, kept in map(cvae4d_epochs, phases))
print(f"{MODEL}: {meta['dataset']['n_train']} training cycles, {epochs} epochs kept ({' then '.join(phases)}), "
      f"beta of {ds.beta.shape[1]} parameters; paper: 13,121 cycles, 5,000 + 200 epochs, beta of 8")
