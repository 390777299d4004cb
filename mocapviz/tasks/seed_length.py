"""CCNet paper Table 7 (§4.8): how the one-step prediction depends on the length of the seed.

For a seed of L frames, the model predicts frame L from frames 0..L-1 only (before them the
causal network sees its zero padding, an LSTM its empty state): windows of L + 1 frames taken
from the test clips every ``every`` frames, each repaired teacher-forced, the last prediction
scored by :func:`mocapviz.metrics.rel_p` against the true frame (the continuous part of the
frame vector in raw units). The predictors that do nothing (:mod:`mocapviz.tasks.do_nothing`)
answer the same question with the same frames.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mocapviz.metrics import rel_p_frames

SEED_LENGTHS = (1, 5, 10, 30, 60, 120)


def predicted_frames(clips: list[dict], longest: int, every: int = 60) -> list[tuple[dict, int]]:
    """(clip, p): the frames p = longest, longest + every, ... of each clip, each to be
    predicted from the seed of L frames before it, for every L up to ``longest``."""
    return [(c, p) for c in clips for p in range(longest, len(c["x"]), every)]


def seed_length_table(repairers: dict, clips: list[dict], lengths=SEED_LENGTHS, every: int = 60) -> pd.DataFrame:
    """Rows (model, seed_frames, rel_p, rel_p_std, n): the mean rel_p (and its std over frames) of the prediction of frame p from the
    L frames before it (nothing before them), over the same predicted frames for every model and
    every L (:func:`predicted_frames`). ``repairers``: name -> an object with
    :class:`mocapviz.tasks.denoising.Repairer`'s ``ref`` and ``repair``."""
    ref = next(iter(repairers.values())).ref
    n = len(ref.x_mean)
    targets = predicted_frames(clips, max(lengths), every)
    rows = []
    for name, rep in repairers.items():
        for length in lengths:
            pred, true = [], []
            for c, p in targets:
                x = np.asarray(c["x"][p - length:p + 1])
                out = rep.repair(ref.norm_x(x), c["skel"], c["traj"][p - length:p + 1], c["type_index"])
                pred.append(out[-1] * ref.x_std + ref.x_mean)
                true.append(x[-1, :n])
            per_frame = rel_p_frames(np.stack(pred), np.stack(true))
            rows.append(dict(model=name, seed_frames=length, rel_p=float(per_frame.mean()),
                             rel_p_std=float(per_frame.std()), n=len(targets)))
    return pd.DataFrame(rows)
