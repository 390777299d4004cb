"""Time-stamped cycles on a clock: reading a chi (4D motion paper §3.1) at given times.

chi's last channel is the timestamp Phi (seconds / ``PHI_SCALE``); models decode it, so a decoded
cycle places its own frames in time. :func:`interpolate_chi` reads any chi at given times (the
observations' times in prediction and completion, a fixed frame rate for Residual-sup);
:func:`time_grid` is a common clock for cycles of different lengths.

Kept out of :mod:`mocapviz.bodies` on purpose: the body4d dataset's cache key hashes that
package's code, so a change there rebuilds the dataset.
"""

from __future__ import annotations

import torch

from mocapviz.features.cycles import MAX_CYCLE_S

PHI_SCALE = MAX_CYCLE_S  # as mocapviz.bodies.representation.PHI_SCALE (chi's timestamps / 3 s)


def chi_times(chi: torch.Tensor) -> torch.Tensor:
    """Frame times (..., N) in seconds from the cycle start: Phi x PHI_SCALE."""
    return chi[..., -1] * PHI_SCALE


def interpolate_chi(chi: torch.Tensor, times: torch.Tensor) -> torch.Tensor:
    """chi (B, N, C) read at ``times`` (B, T) in seconds -> (B, T, C).

    Each channel is linear between the two frames whose timestamps (Phi x PHI_SCALE, made
    non-decreasing by a running maximum) bracket the time; times outside the decoded span take
    the first or last frame. The Phi channel itself comes out as the time when inside the span."""
    t = torch.cummax(chi_times(chi), dim=-1).values  # (B, N)
    times = torch.as_tensor(times, dtype=chi.dtype)
    n = chi.shape[1]
    hi = torch.searchsorted(t.detach().contiguous(), times.detach().contiguous()).clamp(1, n - 1)
    lo = hi - 1
    t0, t1 = t.gather(1, lo), t.gather(1, hi)
    w = ((times - t0) / (t1 - t0).clamp_min(1e-9)).clamp(0.0, 1.0)[..., None]
    idx = lambda i: i[..., None].expand(-1, -1, chi.shape[-1])  # noqa: E731
    return chi.gather(1, idx(lo)) * (1 - w) + chi.gather(1, idx(hi)) * w


def time_grid(durations, fps: float) -> tuple[torch.Tensor, torch.Tensor]:
    """A common clock for cycles of different lengths: times (B, K) = k / fps for k = 0..K-1, with
    K covering the longest duration, and mask (B, K), True where k / fps <= the cycle's duration
    (seconds, (B,)); a small tolerance keeps a duration of exactly k / fps on the grid."""
    durations = torch.as_tensor(durations, dtype=torch.float64)
    k = torch.arange(int(float(durations.max()) * fps + 1e-6) + 1, dtype=torch.float64)
    times = (k / fps).expand(len(durations), -1)
    return times.float(), times <= durations[:, None] + 1e-6
