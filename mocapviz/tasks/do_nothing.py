"""Predictors of the next frame that do nothing clever: the rows every one-step table needs.

Each sees exactly what a causal network sees (the corrupted frames up to t) and predicts frame
t+1, with the :class:`mocapviz.tasks.denoising.Repairer` interface (``repair`` on normalised
frames, reference units), so Table 1 scores them as it scores the networks:

- :class:`CopyLast`: frame t itself;
- :class:`ConstantVelocity`: 2 x_t - x_{t-1};
- :class:`CausalSmoother`: the least-squares polynomial of degree ``degree`` through the last
  ``k`` frames, extrapolated one frame ahead (a linear filter; fewer frames at a clip's start).
  :func:`choose_smoother` picks ``k`` and ``degree`` on validation clips for each noise level.

A network that does not beat these has not learnt to predict the next frame, whatever its
ordering against other networks. (The noisy frame t+1 itself, Table 1's ``noisy_input``, is not
one of them: it sees the frame it is scored on.)
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

SMOOTHER_KS = (2, 3, 4, 6, 8, 12, 16, 24, 32)
SMOOTHER_DEGREES = (0, 1, 2)


class _DoNothing:
    """``repair`` of frames (T, n_x) in reference units -> predictions of frames 1..T-1
    (T-1, n_continuous). ``ref``: the reference normaliser (its continuous width)."""

    def __init__(self, reference):
        self.ref = reference

    def repair(self, x_ref: np.ndarray, skel=None, traj=None, type_index=None) -> np.ndarray:
        x = np.asarray(x_ref, dtype=np.float64)[:, :len(self.ref.x_mean)]
        return self.predict(x)[:-1].astype(np.float32)

    def predict(self, x: np.ndarray) -> np.ndarray:
        """(T, n): row t is the prediction of frame t+1 from frames 0..t."""
        raise NotImplementedError


class CopyLast(_DoNothing):
    name = "copy_last"

    def predict(self, x):
        return x


class ConstantVelocity(_DoNothing):
    name = "constant_velocity"

    def predict(self, x):
        out = x.copy()
        out[1:] = 2 * x[1:] - x[:-1]
        return out


@lru_cache(maxsize=None)
def extrapolation_weights(k: int, degree: int) -> np.ndarray:
    """(k,) w: sum_j w_j x_{t-k+1+j} is the least-squares polynomial of ``degree`` through the k
    frames, evaluated one frame after the last (degree is capped at k - 1)."""
    d = min(degree, k - 1)
    s = np.arange(k, dtype=np.float64) - (k - 1)           # frame offsets, the last at 0
    v = np.vander(s, d + 1, increasing=True)              # (k, d + 1)
    return np.vander(np.array([1.0]), d + 1, increasing=True)[0] @ np.linalg.pinv(v)


class CausalSmoother(_DoNothing):
    def __init__(self, reference, k: int, degree: int):
        super().__init__(reference)
        self.k, self.degree = int(k), int(degree)
        self.name = f"causal_smoother_k{self.k}_d{self.degree}"

    def predict(self, x):
        out = np.empty_like(x)
        k = self.k
        for t in range(min(k - 1, len(x))):               # a clip's first frames: what exists
            out[t] = extrapolation_weights(t + 1, self.degree) @ x[:t + 1]
        if len(x) >= k:
            w = extrapolation_weights(k, self.degree)
            windows = np.lib.stride_tricks.sliding_window_view(x, k, axis=0)  # (T-k+1, n, k)
            out[k - 1:] = windows @ w
        return out


def choose_smoother(reference, clips: list[dict], noise_std: float, seed: int = 0,
                    ks=SMOOTHER_KS, degrees=SMOOTHER_DEGREES) -> tuple[CausalSmoother, dict]:
    """The :class:`CausalSmoother` with the lowest mean per-frame error on ``clips`` (validation
    clips, raw, as ``CCNetDataset.clip_arrays``) under noise ``noise_std`` (normalised units),
    and every candidate's error {(k, degree): mean}. The noise is drawn as Table 1 draws it."""
    from mocapviz.tasks.denoising import add_noise, frame_errors

    n = len(reference.x_mean)
    varying = ~reference.constant_channels()
    data = []
    for c, clip in enumerate(clips):
        clean = reference.norm_x(clip["x"])
        noisy = add_noise(clean, noise_std, n, np.random.default_rng([seed, 99, c]))
        data.append((noisy, clean[1:, :n]))
    scores = {}
    for k in ks:
        for d in degrees:
            if d >= k:
                continue
            s = CausalSmoother(reference, k, d)
            scores[(k, d)] = float(np.concatenate([frame_errors(s.repair(nz), cl, varying) for nz, cl in data]).mean())
    k, d = min(scores, key=scores.get)
    return CausalSmoother(reference, k, d), scores
