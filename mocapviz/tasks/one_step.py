"""One-step prediction, teacher-forced, against the trivial predictors (issue 9's diagnosis).

A network that generates by feeding its own output back must first predict the next frame
from true past frames better than doing nothing does. :func:`one_step_table` measures, per block
of the frame vector (normalised units: training z-scores), over the varying channels of real
clips, the median of

- ``sigma``: the predicted standard deviation (what sampling adds to every frame),
- ``mean_error``: |predicted mean - true next frame|,
- ``copy_last``: |x_t - x_{t+1}|, the error of repeating the last frame,
- ``extrapolate``: |2 x_t - x_{t-1} - x_{t+1}|, the error of constant-velocity extrapolation.

``sigma`` far above ``copy_last`` means a sample is a jump larger than real motion makes in a
frame (noise); ``mean_error`` far above it means the mean barely follows the input, so fed back
it converges on a pose of its own (freezing).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mocapviz.features.motion_types import one_hot
from mocapviz.tasks.denoising import teacher_forced

COLUMNS = ("sigma", "mean_error", "copy_last", "extrapolate")


def one_step_prediction(model, norm, clip: dict) -> tuple[np.ndarray, np.ndarray]:
    """Normalised mean and sigma (T-1, n_continuous) of frames 1..T-1 of a raw clip (dict as
    ``CCNetDataset.clip_arrays``), each from the true frames before it
    (:func:`mocapviz.tasks.denoising.teacher_forced`)."""
    out = teacher_forced(model, norm.norm_x(clip["x"]), norm.norm_skel(clip["skel"]), norm.norm_traj(clip["traj"]),
                         one_hot([clip["type_index"]], model.cfg.n_types)[0])
    return out["mean"], out["sigma"]


def one_step_errors(x_norm: np.ndarray, mean: np.ndarray, sigma: np.ndarray) -> dict[str, np.ndarray]:
    """Absolute values (T-2, n) of the four columns for frames 2..T-1 of one clip: ``x_norm``
    (T, n) true normalised frames, ``mean``/``sigma`` (T-1, n) predictions of frames 1..T-1."""
    x = np.asarray(x_norm)
    return dict(sigma=np.asarray(sigma)[1:], mean_error=np.abs(np.asarray(mean)[1:] - x[2:]),
                copy_last=np.abs(x[2:] - x[1:-1]), extrapolate=np.abs(x[2:] - 2 * x[1:-1] + x[:-2]))


def one_step_table(model, norm, ds, rows) -> pd.DataFrame:
    """Medians of :data:`COLUMNS` per block of x (rows: rot, angvel, pos, vel, root, and "all")
    over the frames of the clips ``rows`` of ``ds`` and the channels that vary in training."""
    n = len(norm.x_mean)
    varying = ~norm.constant_channels()
    blocks = {k: sl for k, sl in ds.layout.x_blocks.items() if sl.stop <= n}
    acc = {k: {c: [] for c in COLUMNS} for k in (*blocks, "all")}
    for r in rows:
        clip = ds.clip_arrays(int(r))
        mean, sigma = one_step_prediction(model, norm, clip)
        errs = one_step_errors(norm.norm_x(clip["x"])[:, :n], mean, sigma)
        for k, sl in (*blocks.items(), ("all", slice(0, n))):
            keep = varying[sl]
            for c in COLUMNS:
                acc[k][c].append(errs[c][:, sl][:, keep].ravel())
    return pd.DataFrame({c: {k: float(np.median(np.concatenate(v[c]))) for k, v in acc.items()} for c in COLUMNS})


def linear_code_residual(x_norm: np.ndarray, widths) -> dict[int, float]:
    """RMS (per channel, normalised units) of what a best linear code of ``k`` numbers cannot
    carry of frames ``x_norm`` (N, D), for each ``k`` in ``widths``: the PCA residual. A network
    whose every layer has C channels passes each frame through C numbers (after CCNet's 1x1
    encoder); with C below the frames' effective dimension it cannot repeat its input frame."""
    x = np.asarray(x_norm, dtype=np.float64)
    x = x - x.mean(axis=0)
    energy = np.linalg.svd(x, compute_uv=False) ** 2
    return {int(k): float(np.sqrt(max(energy[int(k):].sum(), 0.0) / x.size)) for k in widths}
