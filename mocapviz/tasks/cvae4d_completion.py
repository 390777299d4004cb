"""4D completion from spatio-temporally sparse points and markers (4D motion paper §6, Eq. 6,
Figs. 8-9, Table 1).

The paper fits its decoder to CHUM, dense scans (~10,000 points at 50 fps) with 16 synchronised
motion-capture markers. **CHUM is not available**, so our observations are *semi-synthetic*:
they are drawn from the anny meshes of held-out real gait cycles (:func:`observe`):

- ``n_frames`` frames picked uniformly among a cycle's 100 (5, 20, 100), each with its true
  timestamp;
- ``n_points`` (M) points per frame sampled uniformly on the mesh *surface* (a triangle by area,
  then a uniform barycentric point), drawn afresh for every frame (no correspondence across
  frames), optionally with isotropic Gaussian noise;
- 16 "markers": 16 fixed anny vertices placed like a Plug-in-Gait marker subset (:data:`MARKERS`).

Everything is in the cycle's canonical frame (first root at the origin, heading +Z), which
stands in for the paper's manual rigid alignment of each CHUM segment; only (z, beta) are fitted.

**The fit** (:func:`complete`, the paper's Eq. 6): Adam on (z, beta) from z = 0 (the prior's
mean) and the average adult beta, minimising

    L = w_dense L_dense + w_mocap L_mocap + w_time L_time

- ``L_dense``: the symmetric squared Chamfer distance (m^2) between the decoded mesh at the
  observed frames and the observed points. The decoded side is a fixed farthest-point subset of
  anny's vertices (``CompletionConfig.n_vertices``). Nearest neighbours come from scipy's
  KD-tree (no gradient; :func:`nearest`), the distances of the matched pairs are differentiable
  (the Chamfer gradient wherever the nearest neighbour is unique). For speed each Adam step uses
  a seeded random batch of the observed frames (``frames_per_step``) and, for the
  observed -> decoded direction, of each frame's points (``points_per_step``), both unbiased
  estimates of the means they replace; the decoded -> observed direction searches all M points.
- ``L_mocap``: the mean squared distance (m^2) between the decoded marker vertices and the
  observed markers, at the same frames;
- ``L_time``: the mean squared difference between decoded and observed timestamps at the
  observed frames (normalised Phi units, as in training).

**The weights.** Eq. 6's adaptive weights are the paper's [42], GradNorm
(:mod:`mocapviz.training.gradnorm`, its default alpha); ``weighting="gradnorm"`` balances them at the
latent z, the one parameter every task depends on (one output tensor carries chi and beta, so
each task's gradient sees every path). In a 100-step fit it hurts: the time loss starts near
its optimum, its relative rate stays ~1, and GradNorm hands it most of the weight while the
spatial terms fall fast and lose theirs (the two GradNorm rows of ``results/cvae4d_completion.csv``
are worse than their fixed-weight twins). So the default, ``weighting="fixed"``, gives every
present task the weight 1 (m^2 for the spatial terms, normalised Phi^2 for time: all of the same
order at the start). Either way a task whose data is absent (no points: markers only; no
markers: points only) is not in the task list: its weight is zero.
beta is kept inside the shape fit's bounds (``BETA_BOUNDS``) after every step.

**The error** (:func:`chamfer_error_mm`): the symmetric Chamfer distance between the completed
and the true full meshes over all 100 frames, the mean of the two directions' mean
nearest-vertex distances, averaged over frames, in mm (:func:`chamfer`, a KD-tree). Both
meshes are compared at the same :data:`N_EVAL_VERTICES` farthest-point vertices: spread evenly
over the surface like scan points, where anny's own vertices crowd the hands and face (a
vertex average weighs those more: notebook 15 prints both on one fit), and ~10x cheaper.

Why not :func:`mocapviz.tasks.cvae4d_fit.fit_latent` (branch ``pred``): it minimises one summed
loss; completion needs the per-task losses (GradNorm), per-step frame and point batches and
anny's per-parameter beta bounds. The fixed-weight path is that loop with this loss.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import torch
from scipy.spatial import cKDTree

from mocapviz.bodies.anny_model import BETA_BOUNDS, BETA_LABELS, NEUTRAL_BETA
from mocapviz.bodies.representation import PHI_SCALE
from mocapviz.tasks.cvae4d_fit import weights_frozen
from mocapviz.training.gradnorm import GradNorm

# 16 marker vertices (name, nearest anny joint, vertex id), a Plug-in-Gait subset: head front
# (LFHD/RFHD), 7th cervical, clavicle notch, acromions, lateral elbows, wrists, anterior iliac
# spines, lateral knees, toes. Each id is the neutral rest mesh's vertex nearest to a point a few
# cm outside the body from its joint (e.g. the knee's lateral side), chosen once and fixed here.
MARKERS = (
    ("LFHD", "Head", 6987), ("RFHD", "Head", 230),
    ("C7", "Neck", 8251), ("CLAV", "Neck", 5195),
    ("LSHO", "LeftArm", 8220), ("RSHO", "RightArm", 1558),
    ("LELB", "LeftForeArm", 10026), ("RELB", "RightForeArm", 3374),
    ("LWRA", "LeftHand", 9845), ("RWRA", "RightHand", 3193),
    ("LASI", "LeftUpLeg", 10919), ("RASI", "RightUpLeg", 4306),
    ("LKNE", "LeftLeg", 11254), ("RKNE", "RightLeg", 4652),
    ("LTOE", "LeftToeBase", 13078), ("RTOE", "RightToeBase", 6498),
)
MARKER_VERTICES = np.array([m[2] for m in MARKERS], dtype=np.int64)

VARIANTS = ("points+markers", "points", "markers")  # Table 1's red, blue and green rows
TASK_NAMES = ("dense", "mocap", "time")


# ---------------------------------------------------------------------- Chamfer
def nearest(query: np.ndarray, points: np.ndarray, trees=None) -> np.ndarray:
    """Indices (F, Q) of the nearest of ``points`` (F, P, 3) to each of ``query`` (F, Q, 3), frame
    by frame (KD-trees; pass ``trees``, one per frame, to reuse them)."""
    trees = trees if trees is not None else [cKDTree(p) for p in points]
    return np.stack([t.query(q)[1] for t, q in zip(trees, query)]) if len(query) else np.zeros((0, 0), int)


def chamfer(a: np.ndarray, b: np.ndarray, squared: bool = False) -> np.ndarray:
    """Symmetric Chamfer distance (F,) between point sets a (F, P, 3) and b (F, Q, 3) per frame:
    0.5 (mean_i min_j d(a_i, b_j) + mean_j min_i d(a_i, b_j)), d Euclidean (or squared)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    ia, ib = nearest(a, b), nearest(b, a)
    ab = np.linalg.norm(a - np.take_along_axis(b, ia[..., None], 1), axis=-1)
    ba = np.linalg.norm(b - np.take_along_axis(a, ib[..., None], 1), axis=-1)
    if squared:
        ab, ba = ab ** 2, ba ** 2
    return 0.5 * (ab.mean(-1) + ba.mean(-1))


def chamfer_loss(pred: torch.Tensor, obs: torch.Tensor, pred_sample: torch.Tensor | None = None,
                 obs_trees=None) -> torch.Tensor:
    """Squared symmetric Chamfer (scalar, differentiable in ``pred``) between pred (F, V, 3) and
    obs (F, M, 3): 0.5 (mean over pred of the squared distance to the nearest obs point + mean
    over obs of the same to the nearest pred point). ``pred_sample``: obs points (F, M', 3)
    standing in for ``obs`` in the obs -> pred direction (a random subset: an unbiased estimate
    of that mean); ``obs_trees``: KD-trees of ``obs`` per frame (built once per fit)."""
    sample = obs if pred_sample is None else pred_sample
    p = pred.detach().numpy()
    i_po = torch.as_tensor(nearest(p, obs.numpy(), obs_trees))
    i_op = torch.as_tensor(nearest(sample.numpy(), p))
    to_obs = (pred - torch.gather(obs, 1, i_po[..., None].expand(-1, -1, 3))).pow(2).sum(-1).mean()
    to_pred = (sample - torch.gather(pred, 1, i_op[..., None].expand(-1, -1, 3))).pow(2).sum(-1).mean()
    return 0.5 * (to_obs + to_pred)


# ---------------------------------------------------------------------- observations
def surface_points(vertices: np.ndarray, faces: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points (n, 3) uniform on the surface of one mesh (vertices (V, 3), triangles (T, 3)):
    a triangle drawn by area, then a uniform point in it (square-root barycentric trick)."""
    tri = vertices[faces]  # (T, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=-1)
    pick = rng.choice(len(faces), size=n, p=area / area.sum())
    r1, r2 = np.sqrt(rng.random(n))[:, None], rng.random(n)[:, None]
    t = tri[pick]
    return (1 - r1) * t[:, 0] + r1 * (1 - r2) * t[:, 1] + r1 * r2 * t[:, 2]


@dataclass
class Observation:
    """Sparse observations of one cycle: ``frames`` (F,) indices among its 100 frames, ``times``
    (F,) seconds, ``points`` (F, M, 3) or None, ``markers`` (F, 16, 3) or None; metres."""

    frames: np.ndarray
    times: np.ndarray
    points: np.ndarray | None
    markers: np.ndarray | None

    @property
    def variant(self) -> str:
        return {(True, True): "points+markers", (True, False): "points", (False, True): "markers"}[
            (self.points is not None, self.markers is not None)]


def observed_frames(n_total: int, n_frames: int) -> np.ndarray:
    """``n_frames`` indices spread uniformly over ``n_total`` frames, both ends included."""
    return np.unique(np.linspace(0, n_total - 1, n_frames).round().astype(int))


def observe(vertices: np.ndarray, faces: np.ndarray, times: np.ndarray, n_points: int, n_frames: int,
            markers: bool = True, noise_std: float = 0.0, seed: int = 0) -> Observation:
    """Semi-synthetic observations of one true cycle (vertices (N, V, 3), timestamps (N,) s):
    ``n_points`` surface points per observed frame (0: none), the 16 markers if ``markers``,
    at ``n_frames`` uniformly spread frames; Gaussian noise of ``noise_std`` m on both (seeded)."""
    if n_points <= 0 and not markers:
        raise ValueError("nothing observed: give points (n_points > 0) or markers")
    rng = np.random.default_rng(seed)
    frames = observed_frames(len(vertices), n_frames)
    pts = (np.stack([surface_points(vertices[f], faces, n_points, rng) for f in frames])
           if n_points > 0 else None)
    mk = vertices[frames][:, MARKER_VERTICES] if markers else None
    if noise_std > 0:
        pts = None if pts is None else pts + rng.normal(0, noise_std, pts.shape)
        mk = None if mk is None else mk + rng.normal(0, noise_std, mk.shape)
    f32 = (lambda x: None if x is None else np.asarray(x, dtype=np.float32))
    return Observation(frames, np.asarray(times, dtype=np.float64)[frames], f32(pts), f32(mk))


# ---------------------------------------------------------------------- the fit
@dataclass(frozen=True)
class CompletionConfig:
    steps: int = 100
    lr: float = 0.1               # Adam on z and beta
    n_vertices: int = 512         # decoded vertices in L_dense (farthest-point subset)
    frames_per_step: int = 5      # observed frames per Adam step (all if fewer)
    points_per_step: int = 500    # observed points per frame in the obs -> decoded direction
    weighting: str = "fixed"      # every present task weighted 1, or "gradnorm" (module docstring)
    seed: int = 0


def completion_mesher(body, gamma_scale, n_vertices: int):
    """A ChiMesher on anny's farthest-point subset of ``n_vertices`` followed by the 16 markers."""
    from mocapviz.bodies.anny_model import farthest_point_sampling
    from mocapviz.bodies.torch_mesh import ChiMesher

    rest = body.rest_model(NEUTRAL_BETA)["vertices"][0].numpy()
    subset = farthest_point_sampling(rest, n_vertices)
    return ChiMesher(body, gamma_scale, vertices=np.concatenate([subset, MARKER_VERTICES]))


def complete(model, mesher, obs: Observation, cfg: CompletionConfig = CompletionConfig(),
             progress: bool = False) -> dict:
    """Fit (z, beta) to ``obs`` (module docstring); ``mesher`` from :func:`completion_mesher`.
    Returns dict(chi (N, C) numpy, beta (6,), z (L,), seconds, weights (last GradNorm weights,
    0 for an absent task), losses (per step: the task losses))."""
    from tqdm.auto import trange

    t0 = time.process_time()
    gen = torch.Generator().manual_seed(cfg.seed)
    present = (obs.points is not None, obs.markers is not None, True)
    tasks = [n for n, here in zip(TASK_NAMES, present) if here]
    gradnorm = GradNorm(tasks)
    n_beta = len(BETA_LABELS)
    lo, hi = (torch.tensor([BETA_BOUNDS[k][i] for k in BETA_LABELS]) for i in (0, 1))
    z = torch.zeros(1, model.cfg.latent, requires_grad=True)
    beta = torch.as_tensor(NEUTRAL_BETA).clone()[None].requires_grad_(True)
    opt = torch.optim.Adam([z, beta], lr=cfg.lr)
    frames = torch.as_tensor(obs.frames)
    phi_obs = torch.as_tensor(obs.times / PHI_SCALE, dtype=torch.float32)
    points = None if obs.points is None else torch.as_tensor(obs.points)
    markers = None if obs.markers is None else torch.as_tensor(obs.markers)
    trees = None if obs.points is None else [cKDTree(p) for p in obs.points]
    n_sub = mesher.n_vertices - len(MARKER_VERTICES)
    log = []
    with weights_frozen(model):  # only z and beta are fitted
        for _ in trange(cfg.steps, desc="completion fit", disable=not progress, leave=False):
            opt.zero_grad()
            chi = model.decode(z, beta)[0]
            # beta also enters the mesh directly: one output tensor carries chi and beta, so
            # GradNorm's per-task gradients at the output see every path to the parameters
            output = torch.cat([chi.reshape(-1), beta[0]])
            chi_o, beta_o = output[:-n_beta].reshape(chi.shape), output[-n_beta:][None]
            batch = torch.randperm(len(frames), generator=gen)[:cfg.frames_per_step]
            verts = mesher(chi_o[frames[batch]][None], beta_o)[0]  # (F', V' + 16, 3)
            losses = {"time": (chi_o[frames, -1] - phi_obs).pow(2).mean()}
            if points is not None:
                obs_b = points[batch]
                k = min(cfg.points_per_step, obs_b.shape[1])
                pick = torch.stack([torch.randperm(obs_b.shape[1], generator=gen)[:k] for _ in range(len(batch))])
                sample = torch.gather(obs_b, 1, pick[..., None].expand(-1, -1, 3))
                losses["dense"] = chamfer_loss(verts[:, :n_sub], obs_b, sample, [trees[i] for i in batch.tolist()])
            if markers is not None:
                losses["mocap"] = (verts[:, n_sub:] - markers[batch]).pow(2).sum(-1).mean()
            if cfg.weighting == "gradnorm":
                gradnorm.step([losses[n] for n in tasks], output, z)
            else:
                sum(losses[n] for n in tasks).backward()
            opt.step()
            with torch.no_grad():
                beta.copy_(torch.minimum(torch.maximum(beta, lo), hi))
            log.append({n: float(v.detach()) for n, v in losses.items()})
    with torch.no_grad():
        chi = model.decode(z, beta)[0].numpy()
    weights = {n: gradnorm.current().get(n, 0.0) for n in TASK_NAMES}
    return dict(chi=chi, beta=beta.detach()[0].numpy(), z=z.detach()[0].numpy(),
                seconds=time.process_time() - t0, weights=weights, losses=log)


@torch.no_grad()
def chamfer_error_mm(full_mesher, chi: np.ndarray, beta: np.ndarray, truth: np.ndarray) -> float:
    """Mean over frames of the symmetric Chamfer distance (mm) between the full mesh of chi (N, C)
    on beta (6,) and the true full mesh ``truth`` (N, V, 3)."""
    pred = full_mesher(torch.as_tensor(chi)[None], torch.as_tensor(beta)[None])[0].numpy()
    return 1000.0 * float(chamfer(pred, truth).mean())


# ---------------------------------------------------------------------- experiments
# Table 1's grid: points per frame M (0 = markers only) x observed frames; M = 10000 with 100
# frames is the paper's full-scan reference; its spatial completion is the 100-frame column,
# its temporal completion the rows of one M over 5, 20, 100 frames
POINTS = (50, 100, 1000, 10000)
FRAMES = (5, 20, 100)
N_EVAL_VERTICES = 2048  # the error compares farthest-point samplings of both full meshes (module docstring)


def grid(points=POINTS, frames=FRAMES, gradnorm_check: bool = True) -> list[tuple[int, int, str, str]]:
    """(M, frames, variant, weighting) of every fit: points+markers and points for each M and
    frame count, markers only (M = 0) for each frame count; with ``gradnorm_check`` also the
    largest-M, all-frames fit and the markers-only all-frames fit with GradNorm's weights."""
    out = [(m, f, v, "fixed") for f in frames for m in points for v in ("points+markers", "points")]
    out += [(0, f, "markers", "fixed") for f in frames]
    if gradnorm_check:
        out += [(max(points), max(frames), "points+markers", "gradnorm"), (0, max(frames), "markers", "gradnorm")]
    return out


def pick_sequences(ds, per_test_set: int, seed: int = 0) -> np.ndarray:
    """``per_test_set`` held-out cycles of each test set (seeded draw, mirrored copies excluded)."""
    from mocapviz.tasks.cvae4d_eval import test_sets

    rng = np.random.default_rng(seed)
    return np.concatenate([np.sort(rng.choice(idx, min(per_test_set, len(idx)), replace=False))
                           for idx in test_sets(ds).values()])


# full-batch fits (every observed frame and point in every Adam step): do more frames and points
# help once each step sees them all? M = 1000 keeps a 100-frame step near a CPU second
FULL_BATCH_FITS = [(1000, f, "points+markers", "fixed") for f in FRAMES]
BUDGETS = ("minibatch", "full")


def run_completion(model, ds, indices, fits=None, cfg: CompletionConfig = CompletionConfig(), body=None,
                   n_eval_vertices: int = N_EVAL_VERTICES, noise_std: float = 0.0, progress: bool = True,
                   budget: str = "minibatch"):
    """Every fit of ``fits`` (default :func:`grid`) on each cycle of ``indices`` of ``ds`` (on the
    model's translation scale: :func:`mocapviz.tasks.cvae4d_eval.on_scale`). One row per
    (cycle, fit): cycle, test_set, type, M, frames, variant, weighting, budget, error_mm, seconds
    (CPU seconds of the fit), and the fitted chi and beta (for rendering). ``budget``:
    "minibatch" (``cfg``'s frames and points per step) or "full" (all of them in every step)."""
    if budget not in BUDGETS:
        raise ValueError(f"budget must be one of {BUDGETS}, got {budget!r}")
    import pandas as pd
    from tqdm.auto import tqdm

    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.torch_mesh import ChiMesher

    body = body or body_model()
    fits = fits or grid()
    full = ChiMesher(body, ds.gamma_scale)
    mesher = completion_mesher(body, ds.gamma_scale, cfg.n_vertices)
    ev = completion_mesher(body, ds.gamma_scale, n_eval_vertices) if n_eval_vertices else full
    rows = []
    bar = tqdm(total=len(indices) * len(fits), desc="completion", disable=not progress)
    for i in indices:
        with torch.no_grad():
            truth = full(torch.as_tensor(ds.chi[i])[None], torch.as_tensor(ds.beta[i])[None])[0].numpy()
        truth_eval = truth[:, ev.vertex_index.numpy()]
        times = ds.chi[i][:, -1].astype(np.float64) * PHI_SCALE
        for m, f, variant, weighting in fits:
            obs = observe(truth, body.faces, times, m if variant != "markers" else 0, f,
                          markers=variant != "points", noise_std=noise_std, seed=int(i))
            fit_cfg = replace(cfg, weighting=weighting)
            if budget == "full":
                fit_cfg = replace(fit_cfg, frames_per_step=f, points_per_step=max(m, 1))
            out = complete(model, mesher, obs, fit_cfg)
            rows.append(dict(cycle=int(i), test_set=ds.cycles["test_set"].iloc[i], type=ds.cycles["type"].iloc[i],
                             M=m if variant != "markers" else 0, frames=f, variant=variant, weighting=weighting,
                             budget=budget,
                             error_mm=chamfer_error_mm(ev, out["chi"], out["beta"], truth_eval),
                             seconds=out["seconds"], chi=out["chi"], beta=out["beta"]))
            bar.update()
    bar.close()
    return pd.DataFrame(rows)


def summary(rows) -> "pd.DataFrame":
    """Mean error per (M, frames, variant, weighting, budget) over the cycles: mean_mm, n, and the
    mean CPU seconds of one fit."""
    g = rows.groupby(["M", "frames", "variant", "weighting", "budget"], sort=True)
    return g.agg(mean_mm=("error_mm", "mean"), n=("error_mm", "size"), seconds=("seconds", "mean")).reset_index().round(
        {"mean_mm": 2, "seconds": 2})


# the paper's Table 1 (mm): {(M, frames): (points+markers, points)}; M = 0: markers only
PAPER_TABLE1 = {(0, 5): (48, None), (0, 20): (44, None), (0, 100): (43, None),
                (50, 5): (33, 36), (50, 20): (26, 27), (50, 100): (26, 26),
                (100, 5): (31, 33), (100, 20): (25, 25), (100, 100): (24, 24),
                (1000, 5): (29, 30), (1000, 20): (24, 23), (1000, 100): (24, 23),
                (10000, 5): (30, 26), (10000, 20): (25, 21), (10000, 100): (24, 21)}
