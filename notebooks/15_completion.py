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
QUICK = True  # quick: 1 held-out cycle of the quick build, 50 Adam steps per fit; full: the committed table's run
FIG_DIR = "../figures"

# %% [markdown]
# # 15 · Completion from spatio-temporally sparse points and markers (4D motion paper §6, Eq. 6, Figs. 8-9, Table 1)
#
# The decoder of the CVAE maps (z, β) to a whole time-stamped cycle of meshes. Completion
# inverts it: given sparse observations of a cycle, find the (z, β) whose decoded cycle explains
# them; the decoder fills in every missing point and frame. The paper minimises (Eq. 6)
#
# $$\mathcal{L}_{completion} = \omega_{dense}\mathcal{L}_{dense} + \omega_{mocap}\mathcal{L}_{mocap}
#   + \omega_{time}\mathcal{L}_{time}$$
#
# with $\mathcal{L}_{dense}$ the Chamfer distance between the decoded meshes and the observed
# points (no correspondence across frames), $\mathcal{L}_{mocap}$ the L2 distance between 16
# marker vertices and captured markers, $\mathcal{L}_{time}$ the L2 loss on the timestamps, and a
# weight set to zero when its data is absent. The error is the Chamfer distance between the
# completed cycle and the dense truth.
#
# **Our observations are semi-synthetic.** The paper's CHUM scans (68 cameras, ~10,000 points
# per scan, 16 Qualisys markers) are not available. We draw observations from the anny meshes of
# held-out *real* gait cycles: M points per frame sampled uniformly on the mesh surface, drawn
# afresh each frame; 16 fixed anny vertices as markers (listed below); 5, 20 or 100 frames
# picked uniformly with their true timestamps. Everything is in the cycle's canonical frame,
# which stands in for the paper's manual alignment of each segment. The code is
# `mocapviz.tasks.cvae4d_completion` (its docstring gives every choice): Adam on (z, β) from
# z = 0 and the average adult β; Chamfer by KD-trees (scipy), frames and points minibatched per
# step; the error compares the 2,048-vertex farthest-point samplings of both full meshes (mm).

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch
from IPython.display import Image, display

from data_prep.body4d_dataset import Body4DConfig, build_dataset
from mocapviz.bodies import body_model
from mocapviz.bodies.representation import PHI_SCALE
from mocapviz.bodies.torch_mesh import ChiMesher
from mocapviz.tasks.cvae4d_completion import (MARKERS, MARKER_VERTICES, N_EVAL_VERTICES, PAPER_TABLE1,
                                              CompletionConfig, chamfer_error_mm, complete, completion_mesher,
                                              observe, pick_sequences, run_completion, summary)
from mocapviz.tasks.cvae4d_eval import on_scale, reconstruct_cvae
from mocapviz.viz import cycle_strips, save_figure, set_notebook_backend
from mocapviz.zoo import load_cvae4d

torch.set_num_threads(1)
set_notebook_backend(QUICK)
fig_dir = Path(FIG_DIR)
fig_dir.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 160)

# %% [markdown]
# ## The 16 markers
#
# A Plug-in-Gait subset: forehead, C7, clavicle, acromions, lateral elbows, wrists, anterior
# iliac spines, lateral knees, toes; each the anny vertex nearest to a point just outside the
# body from its joint (a test checks each lies near its joint, on its side).

# %%
body = body_model()
print(pd.DataFrame(MARKERS, columns=["marker", "joint", "anny vertex"]).to_string(index=False))

# %% [markdown]
# ## Data and model
#
# The committed phase-2 CVAE. Quick mode fits held-out cycles of the quick build (held out by
# the same rules as the full build's, so the model never saw them); full mode those of the full
# build, the run behind `results/cvae4d_completion.csv`.

# %%
MODEL = "cvae4d_phase2"
model, meta = load_cvae4d(MODEL)
model.eval()
ds = on_scale(build_dataset(Body4DConfig.quick() if QUICK else Body4DConfig(), progress=False),
              meta["dataset"]["gamma_scale"])
cfg = CompletionConfig(steps=50) if QUICK else CompletionConfig()
idx = pick_sequences(ds, 1)[:1] if QUICK else pick_sequences(ds, 12)
print(f"{len(idx)} held-out cycles {idx.tolist()}: {ds.cycles['type'].iloc[idx].tolist()}, "
      f"test sets {ds.cycles['test_set'].iloc[idx].tolist()}; {cfg}")

# %% [markdown]
# ## One completion (Fig. 9): M = 100 points per frame and the markers, all 100 frames

# %%
full = ChiMesher(body, ds.gamma_scale)
i = int(idx[0])
with torch.no_grad():
    truth = full(torch.as_tensor(ds.chi[i])[None], torch.as_tensor(ds.beta[i])[None])[0].numpy()
obs = observe(truth, body.faces, ds.chi[i][:, -1] * PHI_SCALE, 100, 100, markers=True, seed=i)
fit = complete(model, completion_mesher(body, ds.gamma_scale, cfg.n_vertices), obs, cfg)
with torch.no_grad():
    done = full(torch.as_tensor(fit["chi"])[None], torch.as_tensor(fit["beta"])[None])[0].numpy()
ev = completion_mesher(body, ds.gamma_scale, N_EVAL_VERTICES)
sub = ev.vertex_index.numpy()
err = chamfer_error_mm(ev, fit["chi"], fit["beta"], truth[:, sub])
print(f"cycle {i} ({ds.cycles['type'].iloc[i]}, {ds.cycles['subject'].iloc[i]}): Chamfer error {err:.1f} mm, "
      f"fit {fit['seconds']:.1f} CPU s; fitted beta {np.round(fit['beta'], 2)}, true {np.round(ds.beta[i], 2)}")

show = np.linspace(0, 99, 4).round().astype(int)
fig = plt.figure(figsize=(16, 5))
for k, f in enumerate(show):
    ax = fig.add_subplot(1, len(show), k + 1, projection="3d")
    ax.scatter(*done[f][sub].T[[0, 2, 1]], s=0.5, c="0.6", label="completed mesh (vertices)")
    ax.scatter(*obs.points[f].T[[0, 2, 1]], s=6, c="red", label=f"observed points (M = {obs.points.shape[1]})")
    ax.scatter(*obs.markers[f].T[[0, 2, 1]], s=25, c="green", marker="^", label="markers")
    ax.set(title=f"frame {f}", xlabel="x", ylabel="z", zlabel="y")
    ax.set_box_aspect(np.ptp(done[f][sub][:, [0, 2, 1]], axis=0))
    ax.view_init(10, -20)
    ax.set_axis_off()
fig.axes[0].legend(loc="upper left", fontsize=8)
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig09_completion_points.png")
png = fig_dir / "cvae4d_fig09_completion.png"
cycle_strips(body, [truth, done], [f"truth: cycle {i}", f"completed from M = 100 points + 16 markers: {err:.1f} mm"],
             path=png)
display(Image(filename=str(png)))

# %% [markdown]
# ## Spatial, temporal and spatio-temporal completion (Fig. 8, Table 1)
#
# Every fit of the grid on each cycle: points + markers and points only for M = 50, 100,
# 1000, 10000 and 5, 20, 100 frames; markers only for each frame count; and two fits with
# GradNorm's weights (below). Quick mode runs it on its few cycles with few steps; the committed
# table (full mode, `python -m data_prep.cvae4d_completion`) is read from `results/`.

# %%
rows = run_completion(model, ds, idx, cfg=cfg, body=body)
quick_table = summary(rows)
print(f"{len(rows)} fits, {rows.seconds.mean():.1f} CPU s per fit on average (max {rows.seconds.max():.1f}; "
      "target at most 60 s)")
committed = pd.read_csv("../results/cvae4d_completion.csv")


def beside_paper(table: pd.DataFrame) -> pd.DataFrame:
    """Table 1's layout: rows M, columns frames; each cell 'ours (paper)' per variant."""
    t = table[(table.weighting == "fixed") & (table.budget == "minibatch")]
    out = {}
    for (m, f), (pm, p) in PAPER_TABLE1.items():
        cell = t[(t.M == m) & (t.frames == f)].set_index("variant")["mean_mm"]
        if m == 0:
            out[(m, f)] = {"markers only": f"{cell['markers']:.0f} ({pm})"}
        else:
            out[(m, f)] = {"points+markers": f"{cell['points+markers']:.0f} ({pm})",
                           "points only": f"{cell['points']:.0f} ({p})"}
    return pd.DataFrame(out).T.rename_axis(["M", "frames"]).unstack("frames")


print("committed table (full mode; n cycles per cell:", committed.n.min(), "-", committed.n.max(), "): ours (paper), mm")
display(beside_paper(committed))
print("this run (quick mode)" if QUICK else "this run (full mode)")
display(beside_paper(quick_table))

# %%
fig, axes = plt.subplots(1, 2, figsize=(14, 4.5))
t = committed[(committed.weighting == "fixed") & (committed.budget == "minibatch")]
for variant, color in (("points+markers", "red"), ("points", "blue")):
    s = t[(t.variant == variant) & (t.frames == 100)].sort_values("M")
    axes[0].plot(s.M, s.mean_mm, "o-", color=color, label=f"ours: {variant}")
    axes[0].plot(s.M, [PAPER_TABLE1[(m, 100)][variant == "points"] for m in s.M], "x--", color=color,
                 label=f"paper: {variant}")
    s = t[(t.variant == variant) & (t.M == 10000)].sort_values("frames")
    axes[1].plot(s.frames, s.mean_mm, "o-", color=color, label=f"ours: {variant}, M = 10000")
    axes[1].plot(s.frames, [PAPER_TABLE1[(10000, f)][variant == "points"] for f in s.frames], "x--", color=color)
s = t[t.variant == "markers"].sort_values("frames")
axes[0].axhline(float(s[s.frames == 100].mean_mm.iloc[0]), color="green", label="ours: markers only")
axes[0].axhline(PAPER_TABLE1[(0, 100)][0], color="green", ls="--", label="paper: markers only")
axes[1].plot(s.frames, s.mean_mm, "o-", color="green", label="ours: markers only")
axes[1].plot(s.frames, [PAPER_TABLE1[(0, f)][0] for f in s.frames], "x--", color="green")
axes[0].set(xscale="log", xlabel="points per frame M (100 frames)", ylabel="mean Chamfer error (mm)",
            title="spatial completion (Fig. 8 left)")
axes[1].set(xscale="log", xlabel="observed frames", title="temporal completion (Fig. 8 right); x: paper")
axes[0].legend(fontsize=8)
axes[1].legend(fontsize=8)
fig.tight_layout()
save_figure(fig, fig_dir / "cvae4d_fig08_completion.png")

# %% [markdown]
# ## Does the error fall with M and with frames?
#
# Read from the committed table (the sentences are computed, not typed). Each Adam step of the
# table's fits sees at most 5 observed frames and 500 points of each (the minibatch budget), so
# more frames and points can only help through the variety of the draws. The full-batch rows
# (M = 1000, points and markers) give every step every observed frame and point: if the error
# falls with frames there and not in the minibatch cells, the budget hid it; if it stays flat in
# both, a few frames already pin (z, β) down as far as this decoder allows.

# %%
def trend(values: pd.Series, what: str, paper_first: float, paper_last: float) -> str:
    first, last = float(values.iloc[0]), float(values.iloc[-1])
    change = last - first
    verdict = "falls" if change < -1.0 else ("rises" if change > 1.0 else "stays flat (within 1 mm)")
    return (f"{what}: {first:.1f} -> {last:.1f} mm ({change:+.1f} mm): ours {verdict}; "
            f"paper {paper_first:.0f} -> {paper_last:.0f} mm ({paper_last - paper_first:+.0f} mm)")


for variant, col in (("points+markers", 0), ("points", 1)):
    s = t[(t.variant == variant) & (t.frames == 100)].sort_values("M").set_index("M").mean_mm
    print(trend(s, f"{variant}, 100 frames, M 50 -> 10000", PAPER_TABLE1[(50, 100)][col],
                PAPER_TABLE1[(10000, 100)][col]))
    s = t[(t.variant == variant) & (t.M == 10000)].sort_values("frames").set_index("frames").mean_mm
    print(trend(s, f"{variant}, M = 10000, frames 5 -> 100", PAPER_TABLE1[(10000, 5)][col],
                PAPER_TABLE1[(10000, 100)][col]))
s = t[t.variant == "markers"].sort_values("frames").set_index("frames").mean_mm
print(trend(s, "markers only, frames 5 -> 100", PAPER_TABLE1[(0, 5)][0], PAPER_TABLE1[(0, 100)][0]))
pm = t[t.variant == "points+markers"].set_index(["M", "frames"]).mean_mm
po = t[t.variant == "points"].set_index(["M", "frames"]).mean_mm
print(f"markers help the points in {(pm < po).sum()} of {len(pm)} cells, by {(po - pm).mean():.1f} mm on average "
      f"(paper: they help at M = 50-100, not at 10000)")
mk100 = float(t[(t.variant == "markers") & (t.frames == 100)].mean_mm.iloc[0])
print(f"points only (M = 10000, 100 frames) {po[(10000, 100)]:.1f} mm against markers only {mk100:.1f} mm "
      f"(paper: {PAPER_TABLE1[(10000, 100)][1]} against {PAPER_TABLE1[(0, 100)][0]})")
full_batch = committed[committed.budget == "full"].set_index("frames").mean_mm
mini = t[(t.variant == "points+markers") & (t.M == 1000)].set_index("frames").mean_mm
print(trend(full_batch, "points+markers, M = 1000, every frame and point in each Adam step, frames 5 -> 100",
            PAPER_TABLE1[(1000, 5)][0], PAPER_TABLE1[(1000, 100)][0]))
print("  the same cells with the minibatch budget (5 frames, 500 points a step):",
      ", ".join(f"{f} frames {mini[f]:.1f} mm (full batch {full_batch[f]:.1f})" for f in full_batch.index))
g = committed[(committed.M == 10000) & (committed.frames == 100) & (committed.variant == "points+markers")]
gm = committed[(committed.M == 0) & (committed.frames == 100)]
print("GradNorm's weights instead of fixed ones:",
      "; ".join(f"{r.variant} M={r.M}: {r.mean_mm:.1f} mm" for r in pd.concat([g, gm]).itertuples()
                if r.weighting == "gradnorm"), "| fixed:",
      "; ".join(f"{r.variant} M={r.M}: {r.mean_mm:.1f} mm" for r in pd.concat([g, gm]).itertuples()
                if r.weighting == "fixed" and r.budget == "minibatch"))

# %% [markdown]
# ## A reference: the encoder's reconstruction, and the error's vertex sampling
#
# The same error for the model's own reconstruction of each cycle (encoder mean μ, true β), which
# sees the whole truth but only through the encoder; the completion fits the decoder's inputs
# directly. Then the error of the Fig. 9 fit measured two ways: on the 2,048 farthest-point
# vertices (spread evenly over the surface, like scan points; what the table uses) and on every
# anny vertex (anny's vertices crowd the hands and face, so a vertex average weighs them more).

# %%
rec = reconstruct_cvae(model, ds.chi[idx], ds.beta[idx])
with torch.no_grad():
    truths = [full(torch.as_tensor(ds.chi[c])[None], torch.as_tensor(ds.beta[c])[None])[0].numpy()[:, sub] for c in idx]
rec_err = [chamfer_error_mm(ev, rec[k], ds.beta[c], truths[k]) for k, c in enumerate(idx)]
best = rows[rows.weighting == "fixed"].groupby("cycle").error_mm.min()
print(pd.DataFrame({"encoder reconstruction (mm)": np.round(rec_err, 1),
                    "best completion (mm)": best.loc[idx].round(1).values,
                    "type": ds.cycles["type"].iloc[idx].values}, index=idx).to_string())
print(f"the best completion is below the encoder's reconstruction on {(best.loc[idx].values < rec_err).sum()} of "
      f"{len(idx)} cycles")
print(f"check of the error's vertex sampling on the Fig. 9 fit: {N_EVAL_VERTICES} sampled vertices {err:.1f} mm, "
      f"every vertex {chamfer_error_mm(full, fit['chi'], fit['beta'], truth):.1f} mm")

# %% [markdown]
# **The gap and its causes.** The paper reaches ~24 mm with dense scans and 43-48 mm with
# markers alone; its errors fall from 5 to 20 frames and slightly with M. The printed lines
# above say what ours do, from the committed table. Where ours stay flat or above the paper:
#
# - **the fit, not the data, sets our level**: markers alone do about as well as markers with
#   any number of points, and the error hardly moves with M or frames, so what limits it is
#   how far 100 Adam steps from z = 0 get (on a shared CPU; CPU seconds printed above), not how
#   much is observed. A Chamfer term without correspondence has local minima (left and right
#   legs swap easily); the markers' correspondences remove them, which is why points only stay
#   above points with markers (printed above), unlike the paper at large M;
# - **the model**: our CVAE is trained on a few thousand cycles, nearly all from three Bandai
#   actors, for CPU-sized epochs, against the paper's 13,121 AMASS cycles on a GPU; its latent
#   space covers fewer bodies and motions (compare the fitted and true β printed above: anny's
#   six phenotypes trade off against each other in a silhouette);
# - **anny instead of SMPL, and semi-synthetic points**: the points lie exactly on anny's
#   surface (no noise, clothing or holes), which should favour us over real scans; the truth is
#   an anny mesh, the paper's a scan;
# - **the weights**: Eq. 6's adaptive weights are GradNorm ([42]); in a 100-step fit the time
#   loss starts near its optimum, so its relative rate stays ~1 and GradNorm gives it
#   most of the weight, starving the spatial terms: the two GradNorm fits printed above are
#   worse than fixed unit weights (m² for the spatial terms, normalised Φ² for time), which we use.
