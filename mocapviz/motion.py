"""Motion: a skeleton, local joint rotations, root translation and a frame rate."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mocapviz.kinematics import forward_kinematics
from mocapviz.rotations import slerp_matrices
from mocapviz.skeleton import Skeleton

_MIRROR_X = np.diag([-1.0, 1.0, 1.0])


@dataclass(eq=False)
class Motion:
    """Frames of a skeleton's pose, in metres with Y up.

    rotations: (F, J, 3, 3) local joint rotations (global = parent_global @ local);
    root_positions: (F, 3) the root joint's translation; fps: frames per second.
    ``meta`` carries provenance (source file, subject, length unit of the file, ...).

    Readers may pass ``rotations`` as a zero-argument function: the matrices are then
    computed on first access (a file's Euler angles cost as much to convert as to parse,
    and scans that need only the skeleton or the frame count never pay for them).
    """

    skeleton: Skeleton
    rotations: np.ndarray
    root_positions: np.ndarray
    fps: float
    name: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.root_positions = np.asarray(self.root_positions, dtype=np.float64)
        if self.root_positions.ndim != 2 or self.root_positions.shape[1] != 3:
            raise ValueError("root_positions must be (F, 3)")
        if callable(self.rotations):
            self._rotation_factory = self.rotations
            del self.rotations  # __getattr__ computes it on first access
        else:
            self._check_rotations(self.rotations)

    def _check_rotations(self, rotations) -> np.ndarray:
        rotations = np.asarray(rotations, dtype=np.float64)
        if rotations.shape != (self.n_frames, self.skeleton.n_joints, 3, 3):
            raise ValueError(f"rotations must be ({self.n_frames}, {self.skeleton.n_joints}, 3, 3), "
                             f"got {rotations.shape}")
        self.rotations = rotations
        return rotations

    def __getattr__(self, name):
        # Only reached when normal lookup fails: i.e. for rotations not yet computed.
        if name == "rotations" and "_rotation_factory" in self.__dict__:
            return self._check_rotations(self.__dict__.pop("_rotation_factory")())
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __getstate__(self):  # pickling needs the matrices, not the reader's closure
        self.rotations  # noqa: B018 (computes pending rotations)
        return self.__dict__

    @property
    def n_frames(self) -> int:
        return self.root_positions.shape[0]

    @property
    def duration(self) -> float:
        """Time from the first to the last frame, in seconds."""
        return (self.n_frames - 1) / self.fps

    def __getitem__(self, frames) -> "Motion":
        if isinstance(frames, int):
            frames = slice(frames, frames + 1)
        return replace(self, rotations=self.rotations[frames], root_positions=self.root_positions[frames],
                       meta=self._derived_meta(frames))

    def positions(self) -> np.ndarray:
        """Global joint positions (F, J, 3) by forward kinematics."""
        return forward_kinematics(self.rotations, self.root_positions, self.skeleton.offsets,
                                  self.skeleton.parents)

    def resample(self, fps: float) -> "Motion":
        """Resample to ``fps`` over the same time span: slerp for rotations, linear for root."""
        n_new = int(np.floor(self.duration * fps + 1e-9)) + 1
        t = np.arange(n_new) / fps * self.fps  # positions in old-frame units
        i0 = np.clip(np.floor(t).astype(int), 0, self.n_frames - 1)
        i1 = np.minimum(i0 + 1, self.n_frames - 1)
        alpha = t - i0
        rot = slerp_matrices(self.rotations[i0], self.rotations[i1], alpha[:, None])
        root = self.root_positions[i0] * (1 - alpha[:, None]) + self.root_positions[i1] * alpha[:, None]
        return replace(self, rotations=rot, root_positions=root, fps=float(fps), meta=self._derived_meta())

    def mirrored(self) -> "Motion":
        """Left/right mirror image across the world's X = 0 plane (Y up).

        The skeleton is mirrored too (each joint takes its partner's reflected offset), so
        FK of the result equals the reflected FK of the original with joints swapped.
        """
        sk = self.skeleton
        partner = sk.mirror_map()
        offsets = sk.offsets[partner] @ _MIRROR_X
        ends = tuple((int(partner[j]), tuple(np.asarray(off) @ _MIRROR_X)) for j, off in sk.end_sites)
        mirrored_sk = Skeleton(sk.names, sk.parents, offsets, ends)
        rot = _MIRROR_X @ self.rotations[:, partner] @ _MIRROR_X
        root = self.root_positions @ _MIRROR_X
        return replace(self, skeleton=mirrored_sk, rotations=rot, root_positions=root,
                       name=self.name + "_mirror", meta=self._derived_meta())

    def keep_joints(self, names) -> "Motion":
        """Drop whole subtrees (e.g. hands); kept joints move exactly as before."""
        sub, idx = self.skeleton.keep_joints(names)
        meta = self._derived_meta()
        meta.pop("channels", None)  # the file's per-joint channel layout no longer applies
        return replace(self, skeleton=sub, rotations=self.rotations[:, idx], meta=meta)

    def _derived_meta(self, frames: slice | None = None) -> dict:
        """``meta`` for a motion made from this one. Per-frame arrays a reader kept (raw
        channel values, exp-maps) are sliced along with the frames, or dropped when the
        frames themselves change (resampling, mirroring, dropping joints)."""
        def derive(meta: dict) -> dict:
            out = {}
            for key, value in meta.items():
                if isinstance(value, dict):
                    value = derive(value)
                elif isinstance(value, np.ndarray) and value.ndim and len(value) == self.n_frames:
                    if frames is None:
                        continue
                    value = value[frames]
                out[key] = value
            return out
        return derive(self.meta)
