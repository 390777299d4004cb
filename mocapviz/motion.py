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
    """

    skeleton: Skeleton
    rotations: np.ndarray
    root_positions: np.ndarray
    fps: float
    name: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.rotations = np.asarray(self.rotations, dtype=np.float64)
        self.root_positions = np.asarray(self.root_positions, dtype=np.float64)
        f, j = self.rotations.shape[:2]
        if self.rotations.shape[2:] != (3, 3) or j != self.skeleton.n_joints:
            raise ValueError(f"rotations must be (F, {self.skeleton.n_joints}, 3, 3)")
        if self.root_positions.shape != (f, 3):
            raise ValueError("root_positions must be (F, 3)")

    @property
    def n_frames(self) -> int:
        return self.rotations.shape[0]

    @property
    def duration(self) -> float:
        """Time from the first to the last frame, in seconds."""
        return (self.n_frames - 1) / self.fps

    def __getitem__(self, frames) -> "Motion":
        if isinstance(frames, int):
            frames = slice(frames, frames + 1)
        return replace(self, rotations=self.rotations[frames], root_positions=self.root_positions[frames],
                       meta=dict(self.meta))

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
        return replace(self, rotations=rot, root_positions=root, fps=float(fps), meta=dict(self.meta))

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
                       name=self.name + "_mirror", meta=dict(self.meta))

    def keep_joints(self, names) -> "Motion":
        """Drop whole subtrees (e.g. hands); kept joints move exactly as before."""
        sub, idx = self.skeleton.keep_joints(names)
        return replace(self, skeleton=sub, rotations=self.rotations[:, idx], meta=dict(self.meta))
