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
QUICK = True             # quick: the quick dataset's test clips (CI); full: the full test split
MODEL = "ccnet_paper"  # the next-frame CCNet (a name in models/zoo or a .safetensors file)
GENERATOR = "ccnet_generate"  # the generate command's model, for comparison
BASELINES = ("erd_quick", "dae_lstm_quick")
DO_NOTHING = ("copy_last", "constant_velocity", "causal_smoother")  # mocapviz.tasks.do_nothing
FIG_DIR = "../figures"

# %% [markdown]
# # 03 · Motion denoising and completion (CCNet §4.3.1, Table 1, Fig. 4)
#
# A trained CCNet repairs a corrupted clip without any extra training: feed the corrupted frames
# **teacher-forced** (never its own output) and take the mean of the predicted Gaussian of frame
# $t+1$ as the repaired frame (`mocapviz.tasks.denoising`). Table 1 of the paper compares that
# with ERD-4LR and DAE-LSTM after Gaussian noise of std 0.03, 0.05 and 0.1 on the test clips.
#
# **Units.** The noise is added to the *normalised* frame vector (per-channel z-scores of the
# training data): the space the models read and where training added its 0.03 input noise, and
# the only one where one std means the same for radians, metres and m/s. The error is the
# Euclidean distance between repaired and clean frame vectors in the same units, over the
# channels that vary in the training data. Every table carries the predictors that do nothing
# (`mocapviz.tasks.do_nothing`): copying the last noisy frame, constant velocity, and a causal
# smoother (a least-squares polynomial through the last k noisy frames, k and degree chosen on the
# validation clips per noise level). The row `noisy_input` is the error of the noisy frame itself,
# which sees the frame it is scored on (no causal predictor does). **S-CMU**: our 15 CMU clips are all training clips of
# every model (no CMU subject has two clips long enough to hold one out), so S-CMU here is
# in-sample; the paper retrained its models on a CMU selection we do not have.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch

from data_prep.apps_tables import dataset, denoising_clips, denoising_table, load_models
from data_prep.sources import REPO_ROOT
from mocapviz.features.ccnet import FeatureLayout, features_to_motion
from mocapviz.tasks.denoising import Repairer, add_noise, complete_leg, error_shares, sensitivity

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
models = load_models({k: k for k in (MODEL, GENERATOR, *BASELINES)})
ds = dataset(QUICK, n_types=models[MODEL][0].cfg.n_types)
print(f"{MODEL} vs {', '.join(BASELINES)}; dataset {ds.meta['hash']} ({'quick' if QUICK else 'full'}), "
      f"{int((ds.clips.split == 'test').sum())} test clips")

# %% [markdown]
# ## 1 · Table 1: denoising error, ours beside the paper's

# %%
# noise 0 as well: the error of the one-frame prediction from the clean past, the floor of every row
table = denoising_table(models, ds, noise_stds=(0.0, 0.03, 0.05, 0.1), progress=True)
table["model"] = table.model.str.replace(r"causal_smoother\(.*\)", "causal_smoother", regex=True)
ours = table.pivot_table(index=["dataset", "noise_std"], columns="model", values="mean")
ours_sd = table.pivot_table(index=["dataset", "noise_std"], columns="model", values="std")
# the paper's Table 1 (mean, std), from results/paper_ccnet_table1.csv
paper = pd.read_csv(REPO_ROOT / "results" / "paper_ccnet_table1.csv")
PAPER = paper.pivot_table(index=["dataset", "noise_std"], columns="model", values="mean")
PAPER_SD = paper.pivot_table(index=["dataset", "noise_std"], columns="model", values="std")
side = pd.DataFrame({f"ours {m}": ours[m].round(3).astype(str) + " ± " + ours_sd[m].round(3).astype(str)
                     for m in (MODEL, GENERATOR, *BASELINES, *DO_NOTHING, "noisy_input")})
for m in ("ERD-4LR", "DAE-LSTM", "CCNet"):
    side[f"paper {m}"] = PAPER[m].astype(str) + " ± " + PAPER_SD[m].astype(str)
side

# %%
committed = REPO_ROOT / "results" / "ccnet_table1_denoising.csv"
if committed.is_file():   # the full-mode table (python -m data_prep apps-tables)
    full = pd.read_csv(committed)
    print("committed results/ccnet_table1_denoising.csv (full mode):")
    print(full.pivot_table(index=["dataset", "noise_std"], columns="model", values="mean").round(3).to_string())

# %% [markdown]
# **Does the paper's ordering hold** (CCNet's error below both baselines on every row)? And is
# any model better than the noisy input at all? Computed, not typed:

# %%
for (dset, std), r in ours.iterrows():
    best_base = min(r[b] for b in BASELINES)
    best_nothing = min(r[b] for b in DO_NOTHING)
    verdict = "holds" if r[MODEL] < best_base else "does NOT hold"
    print(f"{dset:6s} noise {std:<5}: CCNet {r[MODEL]:.3f} vs best baseline {best_base:.3f} "
          f"({100 * (r[MODEL] - best_base) / best_base:+.1f} %): ordering {verdict}; best do-nothing "
          f"{best_nothing:.3f} (CCNet {'below' if r[MODEL] < best_nothing else 'ABOVE'} it); "
          f"noisy input {r['noisy_input']:.3f} (CCNet {'below' if r[MODEL] < r['noisy_input'] else 'above'} it)")
paper_ratio = (PAPER["CCNet"] / PAPER[["ERD-4LR", "DAE-LSTM"]].min(axis=1)).mean()
our_ratio = (ours[MODEL] / ours[list(BASELINES)].min(axis=1)).mean()
print(f"\nCCNet / best baseline, mean over rows: paper {paper_ratio:.2f}, ours {our_ratio:.2f}")
clips_d = denoising_clips(ds)["D"]
for m in (MODEL, GENERATOR, *BASELINES):
    s = sensitivity(Repairer(*models[m], reference=models[MODEL][1]), clips_d, 0.1)
    print(f"{m}: its repaired frames move by {s:.3f} x the size of input noise of std 0.1 "
          f"(1 = copying the last input frame, 0 = ignoring the input)")

# %% [markdown]
# Which blocks of the frame vector hold the error (clean input, the D clips; share of the summed
# squared error):

# %%
ref = models[MODEL][1]
varying = ~ref.constant_channels()
layout = FeatureLayout(len(ds.joint_names), models[MODEL][0].cfg.n_types)
shares = {}
for name, (m, n) in models.items():
    rep_m = Repairer(m, n, reference=ref)
    pred = np.concatenate([rep_m.repair(ref.norm_x(c["x"]), c["skel"], c["traj"], c["type_index"]) for c in clips_d])
    clean = np.concatenate([ref.norm_x(c["x"])[1:, :len(ref.x_mean)] for c in clips_d])
    shares[name] = error_shares(pred, clean, varying, layout)
pd.DataFrame(shares).round(3)

# %% [markdown]
# **Where the gap comes from.** Every model here *predicts* frame $t+1$ from the noisy past (the
# paper's definition: the repaired frame never sees its own noisy version), so the error has a
# floor, the one-frame prediction error on clean input (the noise-0 row), and the noise adds to it
# only through the past frames; that is why the paper's errors hardly change with the noise std.
# Where that floor is above the noise itself, a model scores worse than the noisy input (the lines
# above say where, and how much each model's output reacts to its input at all); the table of
# blocks says which channels carry the error. The next-frame model is the paper's network with
# two named deviations (its mean is x_t plus the decoder's output, and it is 96 channels wide:
# models/README.md), trained for 80 CPU minutes, not the paper's 2000 epochs on a GPU; the
# generate command's model was trained to generate, not to track its input. Our S-CMU clips are
# training clips, so that dataset is in-sample for every model.

# %% [markdown]
# ## 2 · Fig. 4(a-b): a denoised clip of the held-out subject (noise 0.08)
#
# The right hand's and right toe's height over time: clean, noisy, and CCNet's repair.

# %%
test = ds.clips[(ds.clips.split == "test") & (ds.clips.subject == ds.meta["test_subject"])]
row = int((test.stop - test.start).idxmax())
clip, sk = ds.clip_arrays(row), ds.skeleton(row)
model, norm = models[MODEL]
rep = Repairer(model, norm)
noisy_n = add_noise(norm.norm_x(clip["x"]), 0.08, len(norm.x_mean), np.random.default_rng(0))
noisy = norm.denorm_x(noisy_n)
den = np.array(clip["x"][1:], dtype=np.float64)
den[:, :len(norm.x_mean)] = norm.denorm_x(rep.repair(noisy_n, clip["skel"], clip["traj"], clip["type_index"]))
seqs = {"clean": clip["x"][1:], "noisy 0.08": noisy[1:], f"{MODEL} denoised": den}
pos = {k: features_to_motion(v, sk).positions() for k, v in seqs.items()}
fig, axes = plt.subplots(1, 2, figsize=(12, 3.5))
t = np.arange(len(den)) / ds.config.fps
for ax, joint in zip(axes, ("RightHand", "RightToeBase")):
    j = sk.index(joint)
    for (k, p), c in zip(pos.items(), ("k", "tab:red", "tab:blue")):
        ax.plot(t, p[:, j, 1], color=c, lw=1, label=k)
    ax.set(title=f"{ds.clips['clip'][row]} ({ds.clips.subject[row]}): {joint} height", xlabel="s", ylabel="m")
axes[0].legend()
fig.tight_layout()
fig.savefig(fig_dir / "ccnet_denoising_fig4ab.png", dpi=90)
for k, p in pos.items():
    jit = np.abs(np.diff(p[:, [sk.index("RightHand"), sk.index("RightToeBase")]], 2, axis=0)).mean() * ds.config.fps ** 2
    print(f"{k:>24s}: mean |acceleration| of right hand + toe {jit:.1f} m/s^2, lowest toe {p[:, sk.index('RightToeBase'), 1].min():+.3f} m")

# %% [markdown]
# The same three versions rendered (`mocapviz.viz.apps_scene.denoising_render`, one camera for
# the three panels): the body at the middle of a short window and the paths of both hands
# (orange: left, red: right) and both toes (cyan: left, blue: right) over that window.

# %%
from IPython.display import Image, display

from mocapviz.viz.apps_scene import completion_render, denoising_render

PANEL = (300, 260) if QUICK else (480, 400)   # quick: small panels and a 1.5 s window
win = min(len(den), 90 if QUICK else 180)
a = (len(den) - win) // 2
motions = {k: features_to_motion(v, sk)[a:a + win] for k, v in seqs.items()}
denoising_render(motions, win // 2, path=fig_dir / "ccnet_denoising_fig4ab_render.png", panel_size=PANEL)
display(Image(filename=str(fig_dir / "ccnet_denoising_fig4ab_render.png")))
print(f"frames {a + 1}-{a + win} of {ds.clips['clip'][row]}, {win / ds.config.fps:.1f} s")

# %% [markdown]
# ## 3 · Fig. 4(c-d): completing the right leg
#
# The rotations of the right leg (hip, knee, ankle, toe) set to zero on 30 % of the frames of a
# long test clip, in runs of 0.5 s; CCNet repairs it teacher-forced. The frame vector still holds
# the leg's joint *positions* and velocities on those frames (the paper zeroes rotations only), so
# the network can read the leg from them. The error is the mean distance of the four right-leg
# joints to the truth, root-relative, cm.

# %%
# the longest clip of the held-out subject: a body the network never saw
unseen = (ds.clips.split == "test") & (ds.clips.subject == ds.meta["test_subject"])
long_row = int((ds.clips.stop - ds.clips.start)[unseen].idxmax())
res = complete_leg(rep, ds.clip_arrays(long_row), ds.skeleton(long_row), share=0.3, segment=30, seed=0)
d = res["dropped"]
fig, ax = plt.subplots(figsize=(12, 3.5))
t = np.arange(len(d)) / ds.config.fps
ax.fill_between(t, 0, d * res["corrupted_error"].max(), color="0.9", step="mid", label="rotations zeroed")
ax.plot(t, res["corrupted_error"], color="tab:red", lw=1, label="corrupted input")
ax.plot(t, res["completed_error"], color="tab:blue", lw=1, label=f"{MODEL} completion")
ax.set(title=f"{ds.clips['clip'][long_row]} ({ds.clips.subject[long_row]}, {len(d) / ds.config.fps:.0f} s): right-leg joint error",
       xlabel="s", ylabel="cm")
ax.legend()
fig.tight_layout()
fig.savefig(fig_dir / "ccnet_completion_fig4cd.png", dpi=90)
print(f"on the zeroed frames: corrupted {res['corrupted_error'][d].mean():.1f} cm, "
      f"completed {res['completed_error'][d].mean():.1f} cm; elsewhere the completion is off by "
      f"{res['completed_error'][~d].mean():.1f} cm (its one-frame prediction error)")

# %% [markdown]
# Over every clip of the held-out subject (`data_prep.apps_tables.completion_table`): the leg's
# error on the zeroed frames before and after completion, for each model and the predictors that
# do nothing. A completion helps only where `completed_cm` is below `corrupted_cm`.

# %%
from data_prep.apps_tables import completion_table

completion = completion_table({k: models[k] for k in (MODEL, GENERATOR, *BASELINES)}, ds)
print(completion.round(2).to_string(index=False))
for r in completion.itertuples():
    print(f"{r.model}: the leg's error {'falls' if r.completed_cm < r.corrupted_cm else 'RISES'} from "
          f"{r.corrupted_cm:.1f} to {r.completed_cm:.1f} cm")

# %% [markdown]
# Rendered (`completion_render`): four frames of the first zeroed run, the truth in grey behind
# the corrupted input (left) and CCNet's completion (right).

# %%
long_sk = ds.skeleton(long_row)
comp = {k: features_to_motion(res[k], long_sk) for k in ("truth", "corrupted", "completed")}
first = int(np.flatnonzero(d)[0])
shown = np.minimum(first + np.array([0, 10, 20, 29]), len(d) - 1)
completion_render(comp["truth"], {"corrupted input (right leg zeroed)": comp["corrupted"],
                                  f"{MODEL} completion": comp["completed"]}, shown,
                  path=fig_dir / "ccnet_completion_fig4cd_render.png", panel_size=PANEL)
display(Image(filename=str(fig_dir / "ccnet_completion_fig4cd_render.png")))
print(f"frames {list(shown + 1)}: right-leg error corrupted {np.round(res['corrupted_error'][shown], 1)} cm, "
      f"completed {np.round(res['completed_error'][shown], 1)} cm")
