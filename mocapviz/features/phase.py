"""A local motion phase per frame: where the body is in its movement cycle (an angle).

Why: a network that regresses the mean of the next frame averages the continuations it
cannot tell apart; once its own blurred output is its past, it cannot tell where in the gait
cycle it is, the average of the cycle is a still pose, and generation freezes. A phase input
makes the continuation one instead of many: the network learns the pose at each phase, and in
generation the phase keeps turning however blurred the pose gets (the phase-functioned network
of Holden et al. 2017 and the learned periodic phases of Starke et al. 2022's DeepPhase use the
same idea). Ours needs no labels and no training: the instantaneous (Hilbert) phase of the
clip's main mode of pose change.

The signal is the first principal component of the root-relative joint positions (the ``pos``
block of x minus the root, centred over the clip), band-passed to the frequencies of human
movement cycles. Its sign is fixed so that the component moves the left foot forward, where it
moves the feet at all, so that a walk's phase 0 means the same stride position in every clip.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np
from scipy import signal

from mocapviz.features.ccnet import FPS, FeatureLayout
from mocapviz.skeleton import CCNET_25_JOINTS

BAND_HZ = (0.4, 4.0)   # step cycles of walks to sprints (~0.8-3.5 Hz) and gestures' repetitions
LEFT_FOOT, RIGHT_FOOT = CCNET_25_JOINTS.index("LeftFoot"), CCNET_25_JOINTS.index("RightFoot")


def root_relative_positions(x: np.ndarray, layout: FeatureLayout) -> np.ndarray:
    """(F, J, 3) joint positions minus the root's, from frame vectors x (F, n_x) (raw units)."""
    pos = np.asarray(x, dtype=np.float64)[:, layout.x_blocks["pos"]].reshape(len(x), -1, 3)
    return pos - pos[:, :1]


def phase_signal(x: np.ndarray, layout: FeatureLayout) -> np.ndarray:
    """(F,) the clip's first principal component of root-relative pose over time (metres).

    Sign: positive when the component moves the left foot forward relative to the right (the
    heading frame's +Z); if the feet do not move in it, when its largest loading is positive.
    """
    pos = root_relative_positions(x, layout)
    flat = pos.reshape(len(pos), -1)
    flat = flat - flat.mean(0)
    if len(flat) < 2 or not np.any(flat):
        return np.zeros(len(flat))
    direction = np.linalg.svd(flat, full_matrices=False)[2][0]
    loads = direction.reshape(-1, 3)
    stride = loads[LEFT_FOOT, 2] - loads[RIGHT_FOOT, 2]
    if abs(stride) > 0.1 * np.abs(loads).max():
        sign = np.sign(stride)
    else:
        sign = np.sign(direction[np.argmax(np.abs(direction))])
    return flat @ (sign * direction)


SHORT_SECONDS = 4.0   # inputs shorter than this (seeds) get one fitted sinusoid (see local_phase)


def local_phase(x: np.ndarray, layout: FeatureLayout, fps: float = FPS) -> np.ndarray:
    """(F,) the phase angle (rad, in (-pi, pi]) of every frame of x (F, n_x), 0 at the positive
    peaks of :func:`phase_signal`: its Hilbert phase after a band-pass, or for inputs shorter
    than :data:`SHORT_SECONDS` the phase of one sinusoid fitted to it. Uses the whole of x (a
    clip, or a seed), so a frame's phase sees frames after it.

    Why two estimators: the band-pass and the Hilbert transform need a few cycles; at a short
    seed's last frame (the one generation continues from) their phase was 0.5-1.5 rad off
    (median) on a clean 0.9-2 Hz stride, against 0.01 for the fit."""
    s = phase_signal(x, layout)
    if len(s) < SHORT_SECONDS * fps:
        return fitted_phase(s, fps)
    b, a = signal.butter(2, BAND_HZ, btype="bandpass", fs=fps)  # a 4 s input is far above filtfilt's padding
    return np.angle(signal.hilbert(signal.filtfilt(b, a, s)))


def fitted_phase(s: np.ndarray, fps: float = FPS) -> np.ndarray:
    """(F,) phase of the sinusoid R cos(w t - d) (plus a line) that fits ``s`` (F,) best over
    frequencies in :data:`BAND_HZ`: w t - d per frame. Least squares per frequency on a grid
    (hand-written: scipy's curve_fit needs a starting frequency and finds the nearest local
    optimum; the grid finds the global one)."""
    n = len(s)
    if n < 3 or not np.any(s - s.mean()):
        return np.zeros(n)
    t = np.arange(n) / fps
    best = (np.inf, 0.0, 0.0)
    for hz in np.linspace(*BAND_HZ, 181):
        w = 2 * np.pi * hz
        design = np.stack([np.cos(w * t), np.sin(w * t), np.ones(n), t], axis=1)
        coef, *_ = np.linalg.lstsq(design, s, rcond=None)
        err = np.sum((design @ coef - s) ** 2)
        if err < best[0]:
            best = (err, w, np.arctan2(coef[1], coef[0]))
    _, w, delay = best
    return np.angle(np.exp(1j * (w * t - delay)))


def phase_pace(angle: np.ndarray) -> float:
    """The median phase advance per frame (rad) of phase angles (F,): a seed's pace."""
    steps = np.angle(np.exp(1j * np.diff(np.asarray(angle, dtype=np.float64))))
    return float(np.median(steps)) if len(steps) else 0.0


def phase_channels(angle: np.ndarray) -> np.ndarray:
    """(F, 2) float32 (sin, cos) of phase angles (F,): what the network sees."""
    angle = np.asarray(angle, dtype=np.float64)
    return np.stack([np.sin(angle), np.cos(angle)], axis=-1).astype(np.float32)


def on_circle(channels: np.ndarray) -> np.ndarray:
    """(sin, cos) pairs (..., 2) scaled back onto the unit circle (a network's mean prediction
    shrinks towards 0 where it is unsure; the phase must keep its meaning). (0, 0) becomes (0, 1)."""
    c = np.asarray(channels, dtype=np.float32)
    r = np.linalg.norm(c, axis=-1, keepdims=True)
    return np.where(r > 1e-6, c / np.maximum(r, 1e-6), np.array([0.0, 1.0], dtype=np.float32))


def phase_input(x: np.ndarray, layout: FeatureLayout, fps: float = FPS) -> np.ndarray:
    """(F, 2) what a phase model sees of raw frames x (F, n_x) (a clip, or a seed): the (sin,
    cos) of their :func:`local_phase`."""
    return phase_channels(local_phase(x, layout, fps))


def paced_phase(seed_x: np.ndarray, layout: FeatureLayout, total: int, fps: float = FPS,
                fallback_hz: np.ndarray | None = None) -> np.ndarray:
    """(B, total, 2) phase input for generation from raw seeds (B, S, n_x): each seed's own
    :func:`phase_input`, then its phase turning on at its :func:`phase_pace`; where that pace is
    no faster than the slowest cycle looked for (``BAND_HZ[0]``: the seed shows no cycle) and
    ``fallback_hz`` (B,) gives one above 0, at that pace instead (the motion type's usual one,
    :class:`mocapviz.models.type_prior.TypePrior`). Why: a run from a standing start (CMU 127_03)
    has no step cycle in its first 2 s, and turned on at the band's floor, 0.4 Hz, its phase kept
    the generated legs nearly still while the body glided on (measured: activity 0.16x the real runs')."""
    out = np.zeros((len(seed_x), total, 2), dtype=np.float32)
    for b, sx in enumerate(seed_x):
        angle, pace = seed_phase(sx, layout, fps, None if fallback_hz is None else fallback_hz[b])
        ahead = angle[-1] + pace * np.arange(1, total - len(sx) + 1)
        out[b] = phase_channels(np.concatenate([angle, ahead]))
    return out


def seed_phase(seed_x: np.ndarray, layout: FeatureLayout, fps: float = FPS,
               fallback_hz: float | None = None) -> tuple[np.ndarray, float]:
    """The local phase angle (S,) of raw seed frames (S, n_x) and the pace (rad per frame) it
    turns on at after them: :func:`phase_pace`, or ``fallback_hz`` where the seed shows no cycle
    (see :func:`paced_phase`) or is shorter than one cycle at the pace found (a pace fitted to
    part of a cycle is a guess: on CMU 35_01, a walk at 0.88 Hz, 4-40 frame seeds gave 0.4-4 Hz;
    at 10 frames, 4 Hz made the generated legs move 3x as fast as from any longer seed)."""
    angle = local_phase(seed_x, layout, fps)
    pace = phase_pace(angle)
    hz = pace * fps / (2 * np.pi)
    if fallback_hz is not None and fallback_hz > 0 and (hz <= BAND_HZ[0] + 1e-6 or len(angle) * hz < fps):
        pace = 2 * np.pi * float(fallback_hz) / fps
    return angle, pace


def pace_hz(x: np.ndarray, layout: FeatureLayout, fps: float = FPS) -> float:
    """The :func:`phase_pace` of raw frames x (F, n_x) in cycles per second."""
    return phase_pace(local_phase(x, layout, fps)) * fps / (2 * np.pi)


def clip_phases(ds, cache: bool = True) -> np.ndarray:
    """(N, 2) :func:`phase_input` of every frame of a CCNet dataset, each clip on its own.

    Computed once per dataset content: the result is kept under :func:`dataset_fingerprint`
    (x's bytes, the clips' rows, the layout and fps), so every ``WindowData(phase=True)`` of
    the same dataset, or of a copy loaded again, reuses it, and a dataset whose frames or clips
    changed is computed afresh. Why: one pass is an SVD per clip plus, for clips under
    :data:`SHORT_SECONDS`, a fit over 181 frequencies (tens of seconds for the quick dataset's
    365 clips), and tests, trainers and notebooks build several WindowData of one dataset. ``cache=False`` computes
    without reading or filling the cache. Returns a copy the caller may change."""
    key = dataset_fingerprint(ds) if cache else None
    if key is not None and key in _PHASE_CACHE:
        _PHASE_CACHE.move_to_end(key)
        return _PHASE_CACHE[key].copy()
    out = np.zeros((len(ds.x), 2), dtype=np.float32)
    for r in ds.clips.itertuples():
        out[r.start:r.stop] = phase_input(ds.x[r.start:r.stop], ds.layout, ds.config.fps)
    if key is not None:
        _PHASE_CACHE[key] = out.copy()
        while len(_PHASE_CACHE) > PHASE_CACHE_SIZE:
            _PHASE_CACHE.popitem(last=False)
    return out


PHASE_CACHE_SIZE = 4   # datasets whose clip phases stay in memory (an (N, 2) float32 array each)
_PHASE_CACHE: OrderedDict[str, np.ndarray] = OrderedDict()


def dataset_fingerprint(ds) -> str:
    """A hash of everything :func:`clip_phases` reads of a dataset: the frame vectors x (shape,
    dtype, bytes), each clip's start and stop row, the layout and the frame rate (about 0.1 s for
    the quick dataset's 75 MB of frames, against 18-34 s to compute its phases on a shared CPU)."""
    x = np.ascontiguousarray(ds.x)
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{x.shape} {x.dtype} {ds.layout} {float(ds.config.fps)!r}".encode())
    h.update(memoryview(x).cast("B"))
    for col in ("start", "stop"):
        h.update(np.ascontiguousarray(ds.clips[col].to_numpy(dtype=np.int64)).tobytes())
    return h.hexdigest()
