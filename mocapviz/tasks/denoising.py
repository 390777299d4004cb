"""Motion denoising and completion with CCNet and its baselines (paper §4.3.1, Table 1, Fig. 4).

Both are the same operation: feed a corrupted clip to a model **teacher-forced** (every input is
the corrupted frame, the model's output is never fed back) and take the mean of the predicted
Gaussian of frame t+1 as the repaired frame t+1 (frames before the receptive field see what
exists: the causal zero padding, or the LSTM's empty state). Frame 0 has no past and is not
scored.

Units. The noise is added to the **normalised** frame vector (per-channel z-scores of the
training data, the reference model's normaliser): that is the space the models read, the one
where training added its 0.03 input noise (the paper's 0.03, which is also the smallest test
noise of its Table 1), and the only one where one standard deviation means the same for channels
in radians, metres and m/s. The error is the Euclidean distance between the repaired and the clean
frame vector in the same units, over the continuous channels that vary in the training data (the
constant ones are 0 in both and out of every model's loss). Contact labels are labels, not a
signal: they stay clean.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import torch

from mocapviz.features.ccnet import FeatureLayout, Normaliser
from mocapviz.features.motion_types import one_hot
from mocapviz.features.phase import phase_input

# The right leg of the 25 CCNet joints (Fig. 4(c-d): its rotations are zeroed)
RIGHT_LEG = ("RightUpLeg", "RightLeg", "RightFoot", "RightToeBase")


def teacher_forced(model, x_norm: np.ndarray, skel_norm: np.ndarray, traj_norm: np.ndarray,
                   types: np.ndarray, x_raw: np.ndarray | None = None, posterior: bool = False) -> dict[str, np.ndarray]:
    """The model's outputs (``mean``, ``sigma``: (T-1, n_continuous), normalised) for frames
    1..T-1 of a clip, each predicted from the true frames before it: x_norm (T, n_x) inputs,
    traj_norm (T, 12) c^d of each frame, skel_norm (n_skel,), types (n_types,) one-hot. Input t
    carries x_t and c^d_{t+1} (as in training). A phase model (``CCNetConfig.phase``) also sees
    the local phase of the raw frames ``x_raw`` (T, n_x). With ``posterior`` (a latent model),
    z comes from the posterior given the true next frames, as in training, and the knots'
    ``z_mean`` and ``z_logvar`` (J, latent) are returned too."""
    if model.cfg.phase:
        traj_norm = np.concatenate([traj_norm, phase_input(x_raw, FeatureLayout.of_model(model.cfg))], axis=1)
    model.eval()
    f = lambda a: torch.as_tensor(np.asarray(a, np.float32))[None]  # noqa: E731
    with torch.no_grad():
        target = {"target_x": f(x_norm[1:])} if posterior else {}
        out = model(x=f(x_norm[:-1]), skel=f(skel_norm), traj=f(traj_norm[1:]), types=f(types), **target)
    return {k: out[k][0].numpy() for k in ("mean", "sigma") + (("z_mean", "z_logvar") if posterior else ())}


def teacher_forced_means(model, x_norm: np.ndarray, skel_norm: np.ndarray, traj_norm: np.ndarray,
                         types: np.ndarray, x_raw: np.ndarray | None = None) -> np.ndarray:
    """The means of :func:`teacher_forced`."""
    return teacher_forced(model, x_norm, skel_norm, traj_norm, types, x_raw)["mean"]


def add_noise(x_norm: np.ndarray, std: float, n_continuous: int, rng: np.random.Generator) -> np.ndarray:
    """A copy of normalised frames (T, n_x) with N(0, std^2) on the continuous channels."""
    out = np.array(x_norm, dtype=np.float32, copy=True)
    out[:, :n_continuous] += std * rng.standard_normal((len(out), n_continuous)).astype(np.float32)
    return out


def frame_errors(pred: np.ndarray, clean: np.ndarray, varying: np.ndarray) -> np.ndarray:
    """(T,) Euclidean distance per frame over the ``varying`` channels (bool mask)."""
    return np.linalg.norm((np.asarray(pred) - np.asarray(clean))[:, varying], axis=-1)


class Repairer:
    """One model with its normaliser, repairing raw clips expressed in a reference normaliser.

    ``reference`` fixes the units of the noise and of the error for every model compared (the
    CCNet's normaliser; the baselines trained on the same dataset have the same one, but a model
    with another normaliser is still compared in the same units)."""

    def __init__(self, model, normaliser: Normaliser, reference: Normaliser | None = None):
        self.model, self.norm = model, normaliser
        self.ref = reference or normaliser
        self.n_types = model.cfg.n_types

    def repair(self, x_ref: np.ndarray, skel: np.ndarray, traj: np.ndarray, type_index: int) -> np.ndarray:
        """Frames (T, n_x) in the reference's normalised units (possibly corrupted) -> the
        model's mean of frames 1..T-1 (T-1, n_continuous), in the reference's units."""
        raw = self.ref.denorm_x(x_ref)
        mean = teacher_forced_means(self.model, self.norm.norm_x(raw), self.norm.norm_skel(skel),
                                    self.norm.norm_traj(traj), one_hot([type_index], self.n_types)[0], raw)
        mean[:, self.norm.constant_channels()] = 0.0   # their training value, as the generator writes
        denorm = mean * self.norm.x_std + self.norm.x_mean
        return ((denorm - self.ref.x_mean) / self.ref.x_std).astype(np.float32)


def denoising_errors(repairers: dict[str, Repairer], clips: list[dict], noise_stds, seed: int = 0,
                     progress: bool = False, per_noise=None) -> dict[tuple[float, str], np.ndarray]:
    """Per-frame errors {(noise_std, model): (n_frames,)} over ``clips`` (dicts with raw ``x``,
    ``traj``, ``skel``, ``type_index``, as ``CCNetDataset.clip_arrays``). Every model sees the
    same noisy frames (drawn per noise level and clip from ``seed``). The reference model's
    normaliser (the first repairer's ``ref``) sets the units. Model ``"noisy_input"`` is the
    error of the noisy frame itself (it sees the frame it is scored on, which no causal predictor
    does). ``per_noise``: a function of the noise std giving more repairers for that level only
    (:func:`mocapviz.tasks.do_nothing.choose_smoother` picks a smoother per level)."""
    from tqdm.auto import tqdm

    ref = next(iter(repairers.values())).ref
    varying = ~ref.constant_channels()
    n = len(ref.x_mean)
    errs: dict[tuple[float, str], list] = {}
    for k, std in enumerate(tqdm(list(noise_stds), desc="denoising", disable=not progress)):
        level = dict(repairers, **(per_noise(std) if per_noise else {}))
        for c, clip in enumerate(clips):
            clean = ref.norm_x(clip["x"])
            noisy = add_noise(clean, std, n, np.random.default_rng([seed, k, c]))
            errs.setdefault((std, "noisy_input"), []).append(frame_errors(noisy[1:, :n], clean[1:, :n], varying))
            for name, rep in level.items():
                pred = rep.repair(noisy, clip["skel"], clip["traj"], clip["type_index"])
                errs.setdefault((std, name), []).append(frame_errors(pred, clean[1:, :n], varying))
    return {k: np.concatenate(v) for k, v in errs.items()}


def error_shares(pred: np.ndarray, clean: np.ndarray, varying: np.ndarray, layout: FeatureLayout) -> dict[str, float]:
    """Share of the summed squared error (over frames and the ``varying`` channels) that each
    block of x holds (rot, angvel, pos, vel, root): where a Euclidean error comes from."""
    sq = (np.asarray(pred) - np.asarray(clean)) ** 2 * varying
    total = sq.sum()
    return {k: float(sq[:, sl].sum() / total) for k, sl in layout.x_blocks.items() if sl.stop <= sq.shape[1]}


def sensitivity(repairer: Repairer, clips: list[dict], std: float, seed: int = 0) -> float:
    """How much a model's repaired frames move when noise of ``std`` is added to its input:
    mean over frames of |pred(noisy) - pred(clean)| / mean of |noise| (reference units, varying
    channels). 1 for a model that copies its last input; near 0 for one that ignores its input.
    (The error's change says little: an output shift orthogonal to a large error adds only its
    square.)"""
    ref = repairer.ref
    varying, n = ~ref.constant_channels(), len(ref.x_mean)
    moved, noise = [], []
    for c, clip in enumerate(clips):
        clean = ref.norm_x(clip["x"])
        noisy = add_noise(clean, std, n, np.random.default_rng([seed, c]))
        a, b = (repairer.repair(x, clip["skel"], clip["traj"], clip["type_index"]) for x in (clean, noisy))
        moved.append(frame_errors(b, a, varying))
        noise.append(frame_errors(noisy[:, :n], clean[:, :n], varying))
    return float(np.concatenate(moved).mean() / np.concatenate(noise).mean())


def summary_table(errors: dict[tuple[float, str], np.ndarray], dataset: str) -> pd.DataFrame:
    """Rows (dataset, noise_std, model, mean, std, n) of per-frame errors (std with ddof 0)."""
    return pd.DataFrame([dict(dataset=dataset, noise_std=std, model=name, mean=float(e.mean()),
                              std=float(e.std()), n=int(len(e))) for (std, name), e in errors.items()])


def leg_channels(layout: FeatureLayout, joint_names, joints=RIGHT_LEG) -> np.ndarray:
    """Indices of the exp-map rotation channels of ``joints`` in x."""
    rot = layout.x_blocks["rot"]
    return np.concatenate([np.arange(rot.start + 3 * joint_names.index(j), rot.start + 3 * joint_names.index(j) + 3)
                           for j in joints])


def drop_segments(n_frames: int, share: float, segment: int, rng: np.random.Generator) -> np.ndarray:
    """(n_frames,) bool: non-overlapping runs of ``segment`` frames covering ``share`` of the
    frames (rounded to whole runs), placed by ``rng``; frame 0 is never dropped."""
    n_runs = int(round(share * n_frames / segment))
    slots = (n_frames - 1) // segment
    if n_runs > slots:
        raise ValueError(f"{n_runs} runs of {segment} frames do not fit in {n_frames} frames")
    mask = np.zeros(n_frames, dtype=bool)
    for s in np.sort(rng.choice(slots, n_runs, replace=False)):
        mask[1 + s * segment:1 + (s + 1) * segment] = True
    return mask


def zero_rotations(x_raw: np.ndarray, channels: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """A copy of raw frames (T, n_x) with the rotation ``channels`` set to 0 (identity) on ``frames``."""
    out = np.array(x_raw, copy=True)
    out[np.ix_(np.asarray(frames), channels)] = 0.0
    return out


def leg_errors(x_a: np.ndarray, x_b: np.ndarray, skeleton, joints=RIGHT_LEG) -> np.ndarray:
    """(T,) mean distance (cm) of ``joints`` between two raw frame sequences (T, n_x), each
    posed by FK from its rotations, root-relative in the heading frame (the root path and
    heading do not count: completion is about the leg's pose)."""
    from mocapviz import metrics
    from mocapviz.features.ccnet import features_to_motion

    idx = [skeleton.index(j) for j in joints]
    local = [metrics.local_positions(features_to_motion(x, skeleton).positions(), skeleton)[:, idx]
             for x in (x_a, x_b)]
    return 100.0 * np.linalg.norm(local[0] - local[1], axis=-1).mean(axis=-1)


def complete_leg(repairer: Repairer, clip: dict, skeleton, share: float = 0.3, segment: int = 30,
                 seed: int = 0) -> dict[str, np.ndarray]:
    """Fig. 4(c-d): the right leg's rotations zeroed on ``share`` of the frames (runs of
    ``segment`` frames) of a raw clip, repaired by ``repairer`` teacher-forced. Returns raw
    ``truth``, ``corrupted`` and ``completed`` frames 1..T-1 (completed: the model's mean, the
    clean contact labels), the ``dropped`` mask of those frames, and the leg's joint error (cm)
    per frame of the corrupted input and of the completion against the truth."""
    layout = FeatureLayout(skeleton.n_joints)   # x's blocks: the motion types do not matter
    x = np.asarray(clip["x"])
    mask = drop_segments(len(x), share, segment, np.random.default_rng(seed))
    corrupted = zero_rotations(x, leg_channels(layout, list(skeleton.names)), np.flatnonzero(mask))
    ref = repairer.ref
    pred = repairer.repair(ref.norm_x(corrupted), clip["skel"], clip["traj"], clip["type_index"])
    completed = np.array(x[1:], dtype=np.float64, copy=True)
    completed[:, :pred.shape[1]] = pred * ref.x_std + ref.x_mean
    truth, corrupted = x[1:], corrupted[1:]
    return dict(truth=truth, corrupted=corrupted, completed=completed, dropped=mask[1:],
                corrupted_error=leg_errors(corrupted, truth, skeleton),
                completed_error=leg_errors(completed, truth, skeleton))
