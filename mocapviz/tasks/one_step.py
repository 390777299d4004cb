"""One-step prediction, teacher-forced, against the trivial predictors (the diagnosis of docs/experiments.md).

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

:func:`drift_table` follows the same windows further: the network runs free from a frame on
(its means fed back, the windows' own controls), and its error at each depth is set beside the
error of standing still at the last true frame. A network that tracks its input but drifts
beats standing still for a few frames and then falls behind it; one that does not track its
input starts behind and stays at a constant error (it converges on its own pose).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mocapviz.features.motion_types import one_hot
from mocapviz.tasks.denoising import teacher_forced
from mocapviz.training.trainer import rolled_out

COLUMNS = ("sigma", "mean_error", "copy_last", "extrapolate")


def teacher_forced_clip(model, norm, clip: dict, posterior: bool = False) -> dict[str, np.ndarray]:
    """:func:`mocapviz.tasks.denoising.teacher_forced` on a raw clip (dict as
    ``CCNetDataset.clip_arrays``), normalised by ``norm``."""
    return teacher_forced(model, norm.norm_x(clip["x"]), norm.norm_skel(clip["skel"]), norm.norm_traj(clip["traj"]),
                          one_hot([clip["type_index"]], model.cfg.n_types)[0], clip["x"], posterior=posterior)


def one_step_prediction(model, norm, clip: dict) -> tuple[np.ndarray, np.ndarray]:
    """Normalised mean and sigma (T-1, n_continuous) of frames 1..T-1 of a raw clip (dict as
    ``CCNetDataset.clip_arrays``), each from the true frames before it."""
    out = teacher_forced_clip(model, norm, clip)
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


ROOT_COLUMNS = ("sideways", "forward", "yaw_rate", "height")  # the root block of x, raw units


def root_bias_table(model, norm, ds, rows) -> pd.DataFrame:
    """The teacher-forced one-step root's mean error (predicted - true, raw units: m/s, m/s,
    rad/s, m) per motion type of the clips ``rows``, over all their frames, beside the real
    clips' mean |forward speed| (``real_speed``).

    Why: a bias here is a steady push that generation integrates. A latent model whose mean
    output decodes z = 0 where its clips' posteriors sit elsewhere predicted the standing types
    (waving, gestures) 0.25-0.30 m/s forward from their own true past, and generated wavings
    walked off at that speed whatever plan c^d they were given."""
    root = ds.layout.x_blocks["root"]
    err, speed = {}, {}
    for r in rows:
        clip = ds.clip_arrays(int(r))
        mean, _ = one_step_prediction(model, norm, clip)
        pred = mean[:, root] * norm.x_std[root] + norm.x_mean[root]
        t = ds.clips.type.iloc[int(r)]
        err.setdefault(t, []).append(pred - clip["x"][1:, root])
        speed.setdefault(t, []).append(np.abs(clip["x"][1:, root.start + ROOT_COLUMNS.index("forward")]))
    table = pd.DataFrame({t: np.concatenate(e).mean(0) for t, e in err.items()}, index=list(ROOT_COLUMNS)).T
    table["real_speed"] = pd.Series({t: float(np.concatenate(v).mean()) for t, v in speed.items()})
    return table.rename_axis("type")


def linear_code_residual(x_norm: np.ndarray, widths) -> dict[int, float]:
    """RMS (per channel, normalised units) of what a best linear code of ``k`` numbers cannot
    carry of frames ``x_norm`` (N, D), for each ``k`` in ``widths``: the PCA residual. A network
    whose every layer has C channels passes each frame through C numbers (after CCNet's 1x1
    encoder); with C below the frames' effective dimension it cannot repeat its input frame."""
    x = np.asarray(x_norm, dtype=np.float64)
    x = x - x.mean(axis=0)
    energy = np.linalg.svd(x, compute_uv=False) ** 2
    return {int(k): float(np.sqrt(max(energy[int(k):].sum(), 0.0) / x.size)) for k in widths}


def drift_table(model, data, pairs: np.ndarray, start: int, depths=(1, 5, 10, 30), block: str = "rot") -> pd.DataFrame:
    """Median |error| (normalised units, varying channels of ``block``) of the free-running means
    ``depth`` frames after the last true frame, against standing still at that frame.

    ``data``: a :class:`mocapviz.training.windows.WindowData` (its windows must be longer than
    ``start + max(depths)``); ``pairs``: its (clip, start) windows; the first ``start`` frames
    of each are the true seed, then the model runs free (:func:`mocapviz.training.trainer.rolled_out`).
    Rows: the depths; columns ``free_running`` and ``stand_still``."""
    if start + max(depths) > data.window:
        raise ValueError(f"windows of {data.window} frames cannot reach depth {max(depths)} after frame {start}")
    b = data.batch(np.asarray(pairs))
    x = rolled_out(model, b, start, guided=False)  # a latent model runs on its prior's mean
    sl = data.layout.x_blocks[block]
    keep = b["varying"][sl]
    truth = b["x"][:, :, sl][..., keep]
    last = start - 1
    free = (x[:, :, sl][..., keep] - truth).abs()
    still = (truth[:, last:last + 1] - truth).abs()
    return pd.DataFrame({"free_running": [float(free[:, last + d].median()) for d in depths],
                         "stand_still": [float(still[:, last + d].median()) for d in depths]},
                        index=pd.Index(list(depths), name="depth"))
