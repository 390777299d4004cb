"""Short-term motion prediction on Human3.6M: the protocol of Fragkiadaki et al. 2015 as coded by
Martinez et al. 2017 (CCNet paper §4.7, Table 6), re-implemented on our rotations.

- Data: the exp-map text form (:mod:`mocapviz.io.h36m`), 50 fps, subsampled to 25 fps by keeping
  every second frame from the first. Train on S1, S6, S7, S8, S9, S11; test on S5.
- Test sequences: 8 per action, alternating subactions 1 and 2. Start frames (25 fps) come
  from ``numpy.random.RandomState(1234567890)``: ``randint(16, T_k - 150)`` for k = 1, 2, 1, 2,
  ..., with T_k the 25 fps length of subaction k. A sequence is 50 seed frames from its start,
  then the frames to predict (25 for 1000 ms).
- Error: joint rotations as Euler angles (the papers' ``rotmat2euler``: the file's row-vector
  matrix R gives (atan2(R12, R22), -asin(R02), atan2(R01, R00)); in our column convention
  M = R^T these are the intrinsic Z-Y-X angles of M, reversed). The root's translation and
  rotation channels are left out. Per sequence and frame: the Euclidean norm over the channels
  whose ground truth varies (std over the predicted frames > 1e-4), then the mean over the 8
  sequences; the value at 80 ms is frame 2 of the prediction (k * 40 ms is frame k).

Which channels count: Martinez' ``translate.py`` picks them by the *prediction's* std, which
scores a prediction that does not move as 0; their ``baselines.py`` picks them by the ground
truth's. We use the ground truth's for every model, so a frozen prediction is not rewarded.
The gimbal-lock branch of ``rotmat2euler`` (|R02| exactly 1) is not reproduced: it has measure
zero on real data.

Predictors map (sequences, n_pred) to exp-map rows (N, n_pred, 99): :func:`zero_velocity`, and
:func:`ccnet_predictor` for a CCNet trained on the H3.6M features (``data_prep/h36m_dataset.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from mocapviz.features.ccnet import FeatureLayout, motion_features
from mocapviz.features.motion_types import one_hot
from mocapviz.io._text import parse_number_lines, read_text
from mocapviz.io.h36m import H36M_NAMES, h36m_motion
from mocapviz.motion import Motion
from mocapviz.rotations import rotvec_to_matrix
from mocapviz.tasks.generate import Generator

ACTIONS = ("walking", "eating", "smoking", "discussion")   # Table 6's four actions
TRAIN_SUBJECTS = (1, 6, 7, 8, 9, 11)
TEST_SUBJECT = 5
FPS = 25.0                      # after keeping every second frame of the 50 fps files
N_SEED = 50                     # seed (conditioning) frames
N_SEQUENCES = 8
SRNN_SEED = 1234567890          # Martinez' find_indices_srnn (after Jain et al.'s SRNN code)
HORIZONS_MS = (80, 160, 320, 400, 1000)

# Table 6 of the CCNet paper (Euler-angle MAE, radians), typed from the paper.
PAPER_TABLE6 = {
    "walking": {"ERD-4LR": (0.93, 1.18, 1.59, 1.78, 2.24), "HP-GAN": (0.95, 1.17, 1.69, 1.79, 2.47),
                "QuaterNet": (0.35, 0.64, 1.19, 1.38, 1.58), "AM-GAN": (0.23, 0.51, 0.62, 0.66, 0.84),
                "CCNet": (1.34, 1.40, 1.45, 1.46, 1.55)},
    "eating": {"ERD-4LR": (1.27, 1.45, 1.66, 1.80, 2.02), "HP-GAN": (1.28, 1.47, 1.70, 1.82, 2.51),
               "QuaterNet": (0.31, 0.49, 0.82, 0.97, 1.89), "AM-GAN": (0.20, 0.31, 0.49, 0.66, 1.15),
               "CCNet": (1.35, 1.45, 1.58, 1.65, 2.04)},
    "smoking": {"ERD-4LR": (1.66, 1.95, 2.35, 2.42, 3.14), "HP-GAN": (1.71, 1.89, 2.33, 2.42, 3.20),
                "QuaterNet": (0.32, 0.55, 0.96, 1.07, 1.37), "AM-GAN": (0.25, 0.46, 0.88, 0.88, 1.10),
                "CCNet": (1.81, 1.92, 2.14, 2.21, 2.65)},
    "discussion": {"ERD-4LR": (2.27, 2.47, 2.68, 2.76, 3.11), "HP-GAN": (2.29, 2.61, 2.79, 2.88, 3.67),
                   "QuaterNet": (0.31, 0.67, 0.94, 1.04, 1.96), "AM-GAN": (0.28, 0.55, 0.81, 0.92, 1.58),
                   "CCNet": (1.55, 1.72, 1.83, 1.83, 2.22)},
}


def frames_at_fps(n_frames_50: int) -> int:
    """Frames (25 fps) of a 50 fps take of ``n_frames_50`` frames (every second, from the first)."""
    return (n_frames_50 + 1) // 2


def srnn_starts(n_frames_1: int, n_frames_2: int, seed: int = SRNN_SEED, prefix: int = N_SEED,
                suffix: int = 100) -> list[tuple[int, int]]:
    """(subaction, first seed frame) of the 8 test sequences of one action, from the 25 fps
    lengths of its subactions 1 and 2; subactions alternate 1, 2, 1, ... and the start is drawn
    in [16, T - prefix - suffix) so that 100 frames (4 s) can follow the seed."""
    rng = np.random.RandomState(seed)
    lengths = (n_frames_1, n_frames_2)
    return [(i % 2 + 1, int(rng.randint(16, lengths[i % 2] - prefix - suffix))) for i in range(N_SEQUENCES)]


@dataclass
class SeedSequence:
    """One test sequence: rows of the whole 25 fps take and where the seed starts in it."""

    action: str
    subaction: int
    start: int                # first seed frame (25 fps)
    values: np.ndarray        # (T, 99) the take's exp-map rows at 25 fps
    motion: Motion            # the take at 25 fps with its integrated root (models on poses)

    def seed(self) -> np.ndarray:
        """(50, 99) seed rows."""
        return self.values[self.start:self.start + N_SEED]

    def target(self, n_pred: int) -> np.ndarray:
        """(n_pred, 99) rows to predict."""
        return self.values[self.start + N_SEED:self.start + N_SEED + n_pred]


def read_take(path: str | Path) -> np.ndarray:
    """(F, 99) exp-map rows of one 50 fps file."""
    return parse_number_lines(read_text(path), 99, 1, path, sep=",")


def srnn_sequences(data_dir: str | Path, action: str, subject: int = TEST_SUBJECT) -> list[SeedSequence]:
    """The 8 seeded test sequences of ``action`` for ``subject`` from ``<data_dir>/S<k>/``
    (FileNotFoundError when a subaction file is missing, e.g. S5 discussion)."""
    takes = [read_take(Path(data_dir) / f"S{subject}" / f"{action}_{k}.txt") for k in (1, 2)]
    motions = [h36m_motion(v, root="integrated", every=2, name=f"S{subject}_{action}_{k}")
               for k, v in enumerate(takes, 1)]
    starts = srnn_starts(*(m.n_frames for m in motions))
    return [SeedSequence(action, sub, start, motions[sub - 1].meta["expmap"], motions[sub - 1])
            for sub, start in starts]


def matrix_to_h36m_euler(mats: np.ndarray) -> np.ndarray:
    """Euler angles (..., 3), radians, of the prediction papers' error from our column-convention
    rotations (..., 3, 3): (atan2(M21, M22), -asin(M20), atan2(M10, M00)) -- the intrinsic
    Z-Y-X angles of M in reverse order (tests check against scipy)."""
    m = np.asarray(mats, dtype=np.float64)
    return np.stack([np.arctan2(m[..., 2, 1], m[..., 2, 2]), -np.arcsin(np.clip(m[..., 2, 0], -1.0, 1.0)),
                     np.arctan2(m[..., 1, 0], m[..., 0, 0])], axis=-1)


def expmap_to_euler(expmap: np.ndarray) -> np.ndarray:
    """File exp-maps (..., 3) (row-vector convention, so our rotation is exp(-r)) to Euler angles."""
    return matrix_to_h36m_euler(rotvec_to_matrix(-np.asarray(expmap, dtype=np.float64)))


def euler_channels(rows: np.ndarray) -> np.ndarray:
    """Rows (..., 99) to the evaluated Euler channels (..., 93): joints 1..31, root left out."""
    rows = np.asarray(rows)
    joints = rows[..., 6:].reshape(rows.shape[:-1] + (31, 3))
    return expmap_to_euler(joints).reshape(rows.shape[:-1] + (93,))


def euler_error(target: np.ndarray, pred: np.ndarray) -> np.ndarray:
    """Mean over sequences of the per-frame Euclidean error (T,) between Euler channels
    target and pred (N, T, C), over each sequence's channels whose target varies in time."""
    target, pred = np.asarray(target, dtype=np.float64), np.asarray(pred, dtype=np.float64)
    used = target.std(axis=1, keepdims=True) > 1e-4                  # (N, 1, C)
    return np.sqrt((((target - pred) ** 2) * used).sum(axis=-1)).mean(axis=0)


def at_horizons(errors: np.ndarray, horizons_ms=HORIZONS_MS) -> dict[int, float]:
    """The per-frame error (T,) at each horizon (ms): frame k of the prediction is k * 40 ms."""
    return {ms: float(errors[int(round(ms * FPS / 1000)) - 1]) for ms in horizons_ms}


def zero_velocity(sequences: list[SeedSequence], n_pred: int) -> np.ndarray:
    """The zero-velocity baseline (Martinez et al.): the last seed row repeated, (N, n_pred, 99)."""
    return np.stack([np.repeat(s.seed()[-1:], n_pred, axis=0) for s in sequences])


Predictor = Callable[[list[SeedSequence], int], np.ndarray]   # sequences, n_pred -> (N, n_pred, 99)


def evaluate(predictors: dict[str, Predictor], sequences: dict[str, list[SeedSequence]],
             n_pred: int = 25, horizons_ms=HORIZONS_MS) -> pd.DataFrame:
    """Long table (action, ms, model, mae) of every predictor on every action's sequences."""
    rows = []
    for action, seqs in sequences.items():
        target = euler_channels(np.stack([s.target(n_pred) for s in seqs]))
        for model, predict in predictors.items():
            errors = euler_error(target, euler_channels(predict(seqs, n_pred)))
            rows += [dict(action=action, ms=ms, model=model, mae=e) for ms, e in at_horizons(errors, horizons_ms).items()]
    return pd.DataFrame(rows)


def paper_rows(actions=ACTIONS) -> pd.DataFrame:
    """Table 6 of the paper as (action, ms, model, mae), model names prefixed ``paper_``."""
    return pd.DataFrame([dict(action=a, ms=ms, model=f"paper_{m.lower().replace('-', '_')}", mae=v)
                         for a in actions for m, vals in PAPER_TABLE6[a].items()
                         for ms, v in zip(HORIZONS_MS, vals)])


def ccnet_predictor(model, normaliser):
    """A protocol predictor (sequences, n_pred) -> (N, n_pred, 99) exp-map rows from CCNet: the
    features of the 50 seed frames (49 frame vectors) are fed, then the mean of each predicted
    Gaussian is fed back; joint rotations come from the rotation block (root rows left 0)."""
    def predict(seqs, n_pred):
        feats = [motion_features(s.motion[s.start:s.start + N_SEED], FPS) for s in seqs]
        types = one_hot([ACTIONS.index(s.action) for s in seqs], model.cfg.n_types)
        gen = Generator(model, normaliser, batch=len(seqs))
        out = gen.run(np.stack([f.x for f in feats]), np.stack([f.skel for f in feats]), types, n_pred,
                      seed_traj=np.stack([f.traj for f in feats]))
        layout = FeatureLayout(len(H36M_NAMES), model.cfg.n_types)
        rotvec = out.x[:, out.n_seed:, layout.x_blocks["rot"]]
        rows = np.zeros(rotvec.shape[:2] + (99,))
        rows[..., 3:] = -rotvec          # our rotation exp(v) is the file's exp-map -v
        return rows
    return predict
