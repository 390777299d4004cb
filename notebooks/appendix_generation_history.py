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

# %% [markdown]
# **Runs on demand only**: `make test` (CI) and `make demo` do not execute this appendix. Run it
# with `python tools/run_notebooks.py appendix` or in `make lab`. It loads models that were
# retired from `models/zoo/`: the first code cell fetches each retired checkpoint from the git
# tag `zoo-history-2026-12` into `cache/zoo_history/` (this needs the repository's git history).
# If the library no longer reads a retired checkpoint (an option it used was removed since), run
# this notebook in a checkout of the tag instead: `git worktree add ../zoo-history zoo-history-2026-12`.

# %% tags=["parameters"]
QUICK = True     # quick: the quick dataset and 20 s generations; full: 60 s
FIG_DIR = "../figures"

# %% [markdown]
# # Appendix · How the generation model came about (§4.2)
#
# Notebook `02_motion_generation` shows the recommended model and measures it on poses. This
# appendix keeps the investigation that led there, model by model, each measured with the same
# code on the same seeds: the paper's network freezes; why (the one-step prediction, the width,
# the drift); the phase that keeps the motion turning; a latent $z$ per frame against one blended
# between knots; and the `generate` command's model with its pace and its prior per motion type.
# [docs/experiments.md](../docs/experiments.md) logs every run with its configuration and numbers.

# %%
import subprocess
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep import zoo
from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from mocapviz.tasks.generation_defaults import GENERATION_MODEL, SAMPLING_TEMPERATURE
from mocapviz.tasks.generation_quality import QUALITY_KEYS, TypeBanks, generation_quality, moves_like_real, within_issue_bar
from mocapviz.tasks.one_step import drift_table, linear_code_residual, one_step_table, root_bias_table
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.training.windows import WindowData
from mocapviz.viz import scene, show_figure

torch.set_num_threads(1)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
print("pyvista backend:", scene.set_notebook_backend(QUICK))
HISTORY_TAG = "zoo-history-2026-12"
HISTORY_DIR = Path("../cache/zoo_history")


def load_model(name: str):
    """(model, normaliser, meta) of a zoo model: from models/zoo/ while it is committed there, else
    its files at the tag :data:`HISTORY_TAG`, fetched once into :data:`HISTORY_DIR`."""
    if zoo.committed_path(name).is_file():
        return zoo.load(name)
    path = HISTORY_DIR / f"{name}.safetensors"
    if not path.is_file():
        git = ["git", "-C", ".."]
        listed = subprocess.run(git + ["ls-tree", "--name-only", HISTORY_TAG, "models/zoo/"], capture_output=True,
                                text=True, check=True).stdout.split()
        files = [f for f in listed if Path(f).name.startswith(f"{name}.")]
        if not files:
            raise FileNotFoundError(f"{name}: neither in models/zoo/ nor at the tag {HISTORY_TAG}")
        HISTORY_DIR.mkdir(parents=True, exist_ok=True)
        for f in files:
            blob = subprocess.run(git + ["show", f"{HISTORY_TAG}:{f}"], capture_output=True, check=True).stdout
            (HISTORY_DIR / Path(f).name).write_bytes(blob)
    return load_checkpoint(path)


NAMES = ("ccnet_default", "ccnet_wide", "ccnet_phase", "ccnet_phase_lerp", "ccnet_phase_lerp_scale", GENERATION_MODEL,
         "ccnet_paper")
loaded = {name: load_model(name) for name in NAMES}
for name, (m, _, meta) in loaded.items():
    print(f"{name:24s} C = {m.cfg.channels:3d}, phase {m.cfg.phase}, latent {m.cfg.latent}, validation NLL {meta.get('val_nll')}")

# %%
ds = build_dataset(DatasetConfig.quick() if QUICK else DatasetConfig(), progress=False)
ds = ds.with_vocabulary(min(m.cfg.n_types for m, _, _ in loaded.values()))
banks = TypeBanks(ds)
secs = 20 if QUICK else 60

# %% [markdown]
# ## 1 · Who freezes: every model's pose-level measures
#
# The ten test seeds and the measures of `02_motion_generation`, section 4, with the mean output,
# for the paper's network at the default width (`ccnet_default`), at twice that width and trained
# on its own predictions (`ccnet_wide`), with a phase and a latent $z$ per frame (`ccnet_phase`),
# with $z$ blended between knots (`ccnet_phase_lerp`), trained on every body at many sizes
# (`ccnet_phase_lerp_scale`), the `generate` command's model, and the next-frame predictor
# (`ccnet_paper`); the latent models sampled too.

# %%
quality = {}
for name, (m, nm, _) in loaded.items():
    for mode in ("mean", "sample") if m.cfg.latent else ("mean",):
        quality[name, mode] = generation_quality(m, nm, ds, secs, sample=mode == "sample", banks=banks)
rows = {}
for (name, mode), q in quality.items():
    c = q["per_clip"]
    jitter = [v["jitter_ratio"] for v in c.values()]
    rows[name, mode] = {"seeds": len(c), "move like real": sum(map(moves_like_real, c.values())),
                        "within the moving bar": sum(map(within_issue_bar, c.values())),
                        "freeze at times": sum(v["freezing_share"] > 0 for v in c.values()),
                        "jitter min": min(jitter), "jitter max": max(jitter)}
print(pd.DataFrame(rows).T.round(2).to_string())
print(pd.concat({f"{name}, {mode}": pd.DataFrame(q["per_clip"]).T[list(QUALITY_KEYS)] for (name, mode), q in quality.items()},
                axis=1).astype(float).round(2).T.to_string())

# %% [markdown]
# ## 2 · Why: the one-step prediction
#
# Before a network can run on its own output, it must predict the next frame from the *true*
# past better than doing nothing does. `mocapviz.tasks.one_step` feeds validation clips
# teacher-forced and compares, per block of the frame vector and in training standard
# deviations, the median predicted $\sigma$, the error of the predicted mean, the error of
# repeating the last frame ("copy last"), and of constant-velocity extrapolation. Where the mean
# errs far more than copying does, the mean barely follows its input: fed back, it slides to a
# pose of its own and stays (freezing). Where $\sigma$ is far above a frame's real change, each
# sample jumps farther than real motion moves in a frame (noise).

# %%
val_rows = np.flatnonzero((ds.clips.split == "val").values)[:12]
compared = {name: loaded[name][:2] for name in ("ccnet_default", "ccnet_wide", "ccnet_phase_lerp", "ccnet_paper")}
one_step = {name: one_step_table(m, nm, ds, val_rows) for name, (m, nm) in compared.items()}
print(pd.concat(one_step, axis=1).round(4).to_string())
for name, t in one_step.items():
    r = t.loc["rot"]
    print(f"{name}: median rotation channel: the mean errs by {r.mean_error:.3f} training std, "
          f"{r.mean_error / r.copy_last:.1f}x what repeating the last frame errs; sigma {r.sigma:.3f} std, "
          f"{r.sigma / r.copy_last:.1f}x a real frame's change")

# %% [markdown]
# One cause is width. CCNet's 1x1 encoder passes each frame through C numbers, and its blocks
# carry C channels. How much of the normalised frames can *no* linear code of C numbers carry
# (the PCA residual over the training frames, RMS per channel in training std)?

# %%
norm = loaded["ccnet_default"][1]
varying = ~norm.constant_channels()
train_frames = norm.norm_x(ds.x[np.concatenate([np.arange(r.start, r.stop) for r in ds.clips.itertuples()
                                                if r.split == "train"])])[:, :len(varying)][:, varying]
residual = linear_code_residual(train_frames[::5], [32, 48, 96, 128, 192, 256])
print("beyond a linear code of C numbers (RMS, training std): " + ", ".join(f"C = {k}: {v:.3f}" for k, v in residual.items()))
print("committed: " + ", ".join(f"{name} C = {m.cfg.channels}" for name, (m, _) in compared.items()))

# %% [markdown]
# Width is not the whole story: a run at the paper's width, and runs without dropout or with
# beta-NLL, changed neither the one-step error nor the freezing (docs/experiments.md). The
# network that does track its input is `ccnet_paper`: the paper's stack with a residual mean
# ($\mathbf x_t$ plus the decoder's output). The committed one-step table of the models still in
# the zoo, on the whole validation and test splits (`python -m data_prep one-step`):

# %%
full = pd.read_csv("../results/ccnet_one_step.csv")
print(full.pivot_table(index=["split", "block"], columns="model", values="mean_error").round(4).to_string())

# %% [markdown]
# ## 3 · Running free: where the error grows (drift)
#
# `one_step.drift_table` lets a network run on its own means from frame 48 of 120-frame
# validation windows (with the windows' own trajectory controls) and sets its error at each depth
# beside the error of standing still at the last true frame. A network that does not track its
# input starts far behind standing still and stays at a constant error: it has slid to a pose of
# its own (freezing). One that tracks its input but drifts beats standing still for some frames
# and then falls behind it for good.

# %%
DRIFT_DEPTHS = (1, 5, 10, 30, 71)
drift = {}
for name, (m, nm) in compared.items():
    windows = WindowData(ds, 120, normaliser=nm, phase=m.cfg.phase)
    pick = np.random.default_rng(0).choice(len(windows.val), size=min(64, len(windows.val)), replace=False)
    drift[name] = drift_table(m, windows, windows.val[pick], start=48, depths=DRIFT_DEPTHS)
print(pd.concat(drift, axis=1).round(3).to_string())
for name, t in drift.items():
    ratio = t["free_running"] / t["stand_still"]
    print(f"{name}: free-running error / standing still at depth " + ", ".join(f"{d}: {ratio[d]:.1f}x" for d in (1, 10, 71)))

# %% [markdown]
# ## 4 · The phase: which part matters
#
# `ccnet_phase` and `ccnet_phase_lerp` are told where they are in the movement cycle (notebook
# `02_motion_generation`, section 3). In generation the phase can start as the seed's and turn on
# at the seed's own pace (`phase_source="seed_pace"`), or be fed back as the network predicts it
# (`"network"`), which can stall with the pose. The same seeds, mean output, `ccnet_phase_lerp`:

# %%
lerp, lerp_norm, _ = loaded["ccnet_phase_lerp"]
by_source = {src: generation_quality(lerp, lerp_norm, ds, secs, sample=False, banks=banks, phase_source=src)["per_clip"]
             for src in ("seed_pace", "network")}
print(pd.concat({src: pd.DataFrame(q).T[["type", "freezing_share", "activity_ratio", "jitter_ratio", "root_speed_ratio"]]
                 for src, q in by_source.items()}, axis=1).round(2).to_string())
for src, q in by_source.items():
    print(f"phase_source={src}: {sum(map(moves_like_real, q.values()))} of {len(q)} move like the real clips; "
          f"{sum(c['freezing_share'] > 0 for c in q.values())} freeze at times")

# %% [markdown]
# ## 5 · Sampling: a new $z$ every frame shakes, a blended $z$ moves
#
# Both phase models are conditional VAEs on the causal stack: in training a posterior that sees
# the true next frames gives $z$, in generation the prior does (sampling draws it; the mean output
# takes its mean), and the frame written is the decoder's mean. `ccnet_phase` has one $z$ per
# frame: its posterior then carries each frame's own residual, and independent draws from the
# prior turn into a kick every frame. `ccnet_phase_lerp` has one $z$ per *knot*, and a frame
# between two knots sees their linear blend (`CCNetConfig.latent_lerp`), in training and in
# generation: a new draw bends $z$'s path but never jumps it. Its predicted trajectory control
# is decoded without $z$ (`traj_without_z`): with $z$ in it, the mean output's $z = 0$ planned an
# average pace. Sampled jitter per seed, both models, against the moving bar's limit:

# %%
JITTER_BAR = 3  # the moving bar's jitter limit (mocapviz.tasks.generation_quality.within_issue_bar)
sampled = {"ccnet_phase (z per frame)": quality["ccnet_phase", "sample"]["per_clip"],
           "ccnet_phase_lerp (blended z)": quality["ccnet_phase_lerp", "sample"]["per_clip"]}
fig, ax = plt.subplots(figsize=(10, 3.2))
width = 0.4
for k, (label, q) in enumerate(sampled.items()):
    ax.bar(np.arange(len(q)) + (k - 0.5) * width, [c["jitter_ratio"] for c in q.values()], width, label=label)
ax.axhline(JITTER_BAR, color="crimson", ls="--", label="the moving bar")
ax.set_yscale("log")
ax.set_xticks(np.arange(len(q)), [c["type"] for c in q.values()], fontsize=8)
ax.set_ylabel("sampled jitter / real")
ax.legend(fontsize=7)
fig.tight_layout()
show_figure(fig)
for label, q in sampled.items():
    print(f"{label}: sampled, {sum(map(within_issue_bar, q.values()))} of {len(q)} seeds within the moving bar; "
          f"{sum(map(moves_like_real, q.values()))} pass moves_like_real")

# %% [markdown]
# `ccnet_phase_lerp`'s sampled walk, run and waving seeds over the last 2 s of their
# generation, each with its ratios to the real clips of its type:

# %%
shown = {}  # motion type -> its first sampled Bandai seed
for clip, c in quality["ccnet_phase_lerp", "sample"]["per_clip"].items():
    if c["type"] in ("walk", "jog", "wave") and clip.startswith("dataset-") and c["type"] not in shown:
        shown[c["type"]] = clip
for kind, clip in shown.items():
    c, m = quality["ccnet_phase_lerp", "sample"]["per_clip"][clip], quality["ccnet_phase_lerp", "sample"]["motions"][clip]
    path = fig_dir / f"ccnet_sampled_{kind}_strip.png"
    scene.frame_strip(m[-120:], path, n=8)
    print(f"{clip} ({kind}), sampled: activity {c['activity_ratio']:.2f}x, jitter {c['jitter_ratio']:.2f}x, "
          f"pose distance {c['pose_distance_ratio']:.2f}x, root speed {c['root_speed_ratio']:.2f}x")
    display(Image(filename=str(path)))

# %% [markdown]
# ## 6 · The `generate` command's model: every body at many sizes, the root from the past, at the seed's pace
#
# What the seeds above showed going wrong, and what the command's model does about it:
#
# * **The body.** Most training frames are Bandai's one body, and `ccnet_phase_lerp` learnt its
#   root height, not the body's: the held-out HDM05 subject sank and bent its knees.
#   `ccnet_phase_lerp_scale` trained on every window's body and motion scaled by a random factor
#   (`TrainConfig.body_scale`, `WindowData.scaled`: the same rotations on longer bones).
# * **The root.** A knot of $z$ spans several frames, so the decoder read the root's pace from
#   $z$, and the mean output's $z = 0$ decoded an average pace: the waving walked off. The
#   command's model decodes the root without $z$ (`CCNetConfig.root_without_z`); the table below
#   prints the teacher-forced root error of both on the training clips of the standing types
#   (`mocapviz.tasks.one_step.root_bias_table`).
# * **The pace.** Free-running, the network's own plan $\hat{\mathbf c}^d$ is fed back to it, and
#   where it plans a little slower than it goes, it slows down. `pace="seed"` scales each predicted
#   plan to the speed of the plan the seed's last frame had, as the paper's interactive control
#   scales the plan to the user's speed (§4.4); the direction stays the network's.
# * **The type.** With the root fixed, the waving still stepped its feet in place: $z$ drawn around
#   $0$ decodes an average of all types. The model's type prior (`mocapviz.models.type_prior`) is
#   each motion type's aggregate posterior over the training clips, one Gaussian per type.
#
# The same seeds, mean output and sampled at the command's temperature, with the network's own
# pace and held, and sampled at temperature 1 and from N(0, I) instead of the type prior:

# %%
cmd_model, cmd_norm, _ = loaded[GENERATION_MODEL]
runs = {(pace, mode): generation_quality(cmd_model, cmd_norm, ds, secs, sample=mode == "sample", banks=banks,
                                        pace=pace, temperature=SAMPLING_TEMPERATURE)
        for pace in ("network", "seed") for mode in ("mean", "sample")}
runs["seed", "sample at temperature 1"] = generation_quality(cmd_model, cmd_norm, ds, secs, sample=True, banks=banks,
                                                             pace="seed")
runs["seed", "sample from N(0, I)"] = generation_quality(cmd_model, cmd_norm, ds, secs, sample=True, banks=banks,
                                                         pace="seed", temperature=SAMPLING_TEMPERATURE, type_prior=False)
standing = np.flatnonzero((ds.clips.type.isin(["wave", "raise_hand", "gesture"]) & (ds.clips.split == "train")).values)
print(pd.concat({name: root_bias_table(*loaded[name][:2], ds, standing)
                 for name in ("ccnet_phase_lerp_scale", GENERATION_MODEL)}).round(3).to_string())
for (pace, mode), q in runs.items():
    c = q["per_clip"]
    print(f"{GENERATION_MODEL}, pace {pace:7s}, {mode:26s}: {sum(map(within_issue_bar, c.values()))} of {len(c)} "
          f"within the moving bar, {sum(map(moves_like_real, c.values()))} move like the real clips; root speed "
          f"{min(v['root_speed_ratio'] for v in c.values()):.2f}-{max(v['root_speed_ratio'] for v in c.values()):.2f}x")
print(pd.concat({f"{pace}, {mode}": pd.DataFrame(q["per_clip"]).T[["activity_ratio", "jitter_ratio", "root_speed_ratio",
                                                                  "root_height_ratio"]]
                 for (pace, mode), q in runs.items() if mode == "mean"}, axis=1).astype(float).round(2).to_string())
print("the waving, sampled at the seed's pace, with the type prior and from N(0, I):")
print(pd.concat({mode: pd.DataFrame(runs["seed", mode]["per_clip"]).T.query("type == 'wave'")[
    ["activity_ratio", "jitter_ratio", "root_speed_ratio"]].astype(float).round(2)
    for mode in ("sample", "sample from N(0, I)")}, axis=1).to_string())

# %% [markdown]
# The held-out subject's jog and the Bandai run, mean output at the seed's pace, the last 2 s of
# the generation:

# %%
for clip, c in runs["seed", "mean"]["per_clip"].items():
    if c["type"] != "jog":
        continue
    path = fig_dir / f"ccnet_command_{clip}_strip.png"
    scene.frame_strip(runs["seed", "mean"]["motions"][clip][-120:], path, n=8)
    print(f"{clip}: activity {c['activity_ratio']:.2f}x, jitter {c['jitter_ratio']:.2f}x, root speed "
          f"{c['root_speed_ratio']:.2f}x, root height {c['root_height_ratio']:.2f}x the seed's")
    display(Image(filename=str(path)))

# %% [markdown]
# ## 7 · What else was tried
#
# `docs/experiments.md` records the other runs, each with its configuration and numbers: a
# residual mean on every channel (it drifts without bound) and on the rotations and positions
# only (it never freezes but tumbles through impossible poses); a leaky residual (it freezes);
# constant input offsets as noise (no effect on the drift); training on its own predictions
# (`feedback_passes`) and on whole free-running stretches of each window (the one-step error rose
# and the drift came sooner, section 3's measure); a per-frame latent $z$ drawn instead of the
# frame (sampled frames then vary by $z$, but the mean output still froze on most seeds); and the
# phase as an input only (the network then barely used it).
