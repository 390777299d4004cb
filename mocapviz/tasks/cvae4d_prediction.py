"""4D motion prediction (4D motion paper §5, Fig. 7): the CVAE against Residual-sup.

Given the first ``observed_s`` = 0.25 s of a held-out cycle (its own frames, with their real
timestamps), predict the rest:

- **CVAE** (:func:`predict_cvae`): Adam on (z, beta) so that the decoded cycle, read at the
  observed timestamps, matches the observed vertices (:mod:`mocapviz.tasks.cvae4d_fit`; the
  loss on a fixed vertex subset of ``fit_vertices`` vertices, the error on every vertex); the
  fitted (z, beta) decodes the whole cycle, meshed on the *fitted* beta;
- **Residual-sup** (:func:`predict_residual`): the cycle resampled to 100 fps, the frames of the
  first 0.25 s fed to the GRU, the rest rolled out; meshed on the *true* beta (the paper's
  protocol, which favours the baseline);
- **error over time** (:func:`prediction_errors`, :func:`error_table`): every model and the
  truth are read on one clock, t = k / 100 s up to each cycle's real duration (the truth and
  the CVAE by their timestamps; a decoded cycle shorter than the truth holds its last frame);
  at each t the Euclidean distance between corresponding vertices (all of anny's, metres ->
  mm) averaged over vertices, then over the cycles at least t long (the paper's Fig. 7 mean;
  ``n`` says how many). Residual-sup's frames before 0.25 s are its input (the truth), so its
  error there is zero by construction; ``observed`` marks those rows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import torch

from mocapviz.bodies.representation import PHI_SCALE
from mocapviz.features.chi_time import chi_times, interpolate_chi, time_grid
from mocapviz.tasks.cvae4d_fit import FitConfig, FitResult, fit_to_vertices
from mocapviz.training.residual_sup import grid_frames, labels_for, n_observed


@dataclass(frozen=True)
class PredictionSetup:
    observed_s: float = 0.25
    fps: float = 100.0           # the common clock of the error (and Residual-sup's frame rate)
    fit: FitConfig = field(default_factory=FitConfig)
    fit_vertices: int = 512      # vertices in the fit loss (farthest-point subset)
    batch: int = 64              # cycles fitted together (independent fits, one Adam)


def observed_window(chi: torch.Tensor, observed_s: float) -> tuple[torch.Tensor, torch.Tensor]:
    """The cycle's own frames before ``observed_s``: times (B, T) in seconds and mask (B, T),
    T the largest count in the batch (frames are in time order, so they are chi[:, :T])."""
    t = chi_times(torch.as_tensor(chi))
    mask = t < observed_s - 1e-9
    n = int(mask.sum(1).max())
    return t[:, :n], mask[:, :n]


def predict_cvae(model, mesher, chi, beta_true, beta0, setup: PredictionSetup = PredictionSetup()) -> FitResult:
    """Fit (z, beta) of cycles chi (B, N, C) to their observed window (vertices of the true chi on
    the true beta, by ``mesher``), starting from z = 0 and ``beta0`` (B, n_beta)."""
    chi = torch.as_tensor(chi, dtype=torch.float32)
    times, mask = observed_window(chi, setup.observed_s)
    with torch.no_grad():
        targets = mesher(chi[:, :times.shape[1]], torch.as_tensor(beta_true, dtype=torch.float32))
    return fit_to_vertices(model, mesher, targets, times, beta0, mask=mask, cfg=setup.fit)


@torch.no_grad()
def predict_residual(model, chi, types, setup: PredictionSetup = PredictionSetup()) -> torch.Tensor:
    """Residual-sup's cycles (B, K, C) on the ``setup.fps`` clock (K covering the longest cycle):
    the observed frames, then the rollout; Phi = k / fps (normalised)."""
    frames, _ = grid_frames(chi, setup.fps)
    k = n_observed(setup.fps, setup.observed_s)
    pred = model(frames[:, :k], labels_for(model, types), frames.shape[1] - k)
    out = torch.cat([frames[:, :k], pred], 1)
    phi = torch.arange(out.shape[1], dtype=out.dtype) / setup.fps / PHI_SCALE
    return torch.cat([out, phi.expand(out.shape[0], -1)[..., None]], -1)


@dataclass
class Predictions:
    times: torch.Tensor               # (B, K) seconds, the common clock
    mask: torch.Tensor                # (B, K) True up to each cycle's real duration
    truth: torch.Tensor               # (B, K, C) the true chi on the clock
    chi: dict                         # model -> (B, K, C) its prediction on the clock
    beta: dict                        # model -> (B, n_beta) the body it is meshed on
    errors: dict = field(default_factory=dict)  # model -> (B, K) mean vertex error, mm
    fit_seconds: float = 0.0          # wall time of all CVAE fits


@torch.no_grad()
def vertex_errors_on_clock(mesher, truth, beta_true, chi, beta, batch: int = 4) -> torch.Tensor:
    """(B, K) mean distance (mm) between corresponding vertices of the truth and a prediction,
    both (B, K, C) on the same clock, meshed on ``beta_true`` and ``beta`` (B, n_beta)."""
    out = []
    for i in range(0, len(truth), batch):
        s = slice(i, i + batch)
        a = mesher(truth[s], beta_true[s], vertex_major=True)
        b = mesher(chi[s], beta[s], vertex_major=True)
        out.append(1000 * (a - b).norm(dim=-1).mean(1))
    return torch.cat(out)


def prediction_errors(ds, idx, cvaes: dict, baselines: dict, setup: PredictionSetup = PredictionSetup(),
                      body=None, progress: bool = False) -> Predictions:
    """Predict cycles ``idx`` of a body4d dataset (on the models' translation scale: see
    :func:`mocapviz.tasks.cvae4d_eval.on_scale`) with each CVAE (name -> model) and each
    Residual-sup (name -> model); their errors over time on the common clock."""
    from tqdm.auto import tqdm

    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.torch_mesh import ChiMesher
    from mocapviz.training.cvae4d import make_mesher, split_indices

    body = body or body_model()
    idx = np.asarray(idx)
    chi = torch.as_tensor(ds.chi[idx], dtype=torch.float32)
    beta = torch.as_tensor(ds.beta[idx], dtype=torch.float32)
    types = ds.cycles["type"].to_numpy()[idx]
    times, mask = time_grid(chi_times(chi)[:, -1], setup.fps)
    pred = Predictions(times, mask, interpolate_chi(chi, times), {}, {})
    train_idx, _ = split_indices(ds)
    beta0 = torch.as_tensor(ds.beta[train_idx].mean(0), dtype=torch.float32)  # the training bodies' mean
    fit_mesher = make_mesher(body, ds.gamma_scale, setup.fit_vertices)
    for name, model in cvaes.items():
        t0, chis, betas = time.perf_counter(), [], []
        for i in tqdm(range(0, len(idx), setup.batch), desc=f"fit {name}", disable=not progress):
            s = slice(i, i + setup.batch)
            res = predict_cvae(model, fit_mesher, chi[s], beta[s], beta0.expand(len(chi[s]), -1), setup)
            chis.append(interpolate_chi(res.chi, times[s]))
            betas.append(res.beta)
        pred.fit_seconds += time.perf_counter() - t0
        pred.chi[name], pred.beta[name] = torch.cat(chis), torch.cat(betas)
    for name, model in baselines.items():
        pred.chi[name], pred.beta[name] = predict_residual(model, chi, types, setup), beta
    mesher = ChiMesher(body, ds.gamma_scale)
    for name in tqdm(list(pred.chi), desc="vertex errors", disable=not progress):
        pred.errors[name] = vertex_errors_on_clock(mesher, pred.truth, beta, pred.chi[name], pred.beta[name])
    return pred


def error_table(pred: Predictions, setup: PredictionSetup = PredictionSetup()) -> pd.DataFrame:
    """One row per model and clock time: ``model, t_s, mean_mm`` (mean over the ``n`` cycles at
    least t long), ``observed`` (t inside the observed window)."""
    rows = []
    m = pred.mask.double()
    n = m.sum(0)
    t = pred.times[0].double().numpy()
    for name, err in pred.errors.items():
        mean = (err.double() * m).sum(0) / n.clamp_min(1)
        rows.append(pd.DataFrame(dict(model=name, t_s=t.round(3), mean_mm=mean.numpy().round(2),
                                      n=n.long().numpy(), observed=t < setup.observed_s - 1e-9)))
    return pd.concat(rows, ignore_index=True)


def ordering(table: pd.DataFrame, ours: str, baseline: str, min_n: int = 1) -> dict:
    """Is ``ours`` below ``baseline`` over the predicted times (rows not ``observed``, at least
    ``min_n`` cycles)? {n_times, share_below (of those times), mean_ours, mean_baseline (mm,
    averaged over the times), first_t_below / last_t_below (None if never), crossing times}."""
    pred = table[~table["observed"] & (table["n"] >= min_n)]
    a = pred[pred["model"] == ours].set_index("t_s")["mean_mm"]
    b = pred[pred["model"] == baseline].set_index("t_s")["mean_mm"]
    a, b = a.align(b, join="inner")
    below = (a < b).to_numpy()
    t = a.index.to_numpy()
    flips = t[1:][below[1:] != below[:-1]] if len(t) > 1 else np.zeros(0)
    return dict(n_times=len(t), share_below=float(below.mean()) if len(t) else float("nan"),
                mean_ours=float(a.mean()), mean_baseline=float(b.mean()),
                first_t_below=float(t[below][0]) if below.any() else None,
                last_t_below=float(t[below][-1]) if below.any() else None, crossings=[float(x) for x in flips])
