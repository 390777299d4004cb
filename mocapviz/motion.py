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
    ``translations`` maps the index of a non-root joint that moves relative to its parent
    (BVH position channels below the root: Perception Neuron, Blender re-exports) to its
    per-frame local position (F, 3), which replaces ``skeleton.offsets[j]`` in forward
    kinematics; the other joints (most, usually all) are rigid and pay nothing.
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
    translations: dict = field(default_factory=dict)

    def __post_init__(self):
        self.root_positions = np.asarray(self.root_positions, dtype=np.float64)
        if self.root_positions.ndim != 2 or self.root_positions.shape[1] != 3:
            raise ValueError("root_positions must be (F, 3)")
        self.translations = {int(j): np.asarray(t, dtype=np.float64) for j, t in self.translations.items()}
        for j, t in self.translations.items():
            if not 0 < j < self.skeleton.n_joints or t.shape != (self.n_frames, 3):
                raise ValueError(f"translations[{j}] must be a non-root joint's (F, 3) = "
                                 f"({self.n_frames}, 3) local positions, got {t.shape}")
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
                       translations={j: t[frames] for j, t in self.translations.items()},
                       meta=self._derived_meta(frames))

    def positions(self) -> np.ndarray:
        """Global joint positions (F, J, 3) by forward kinematics, in metres."""
        return self.global_pose()[0]

    def global_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Global joint positions (F, J, 3) and rotations (F, J, 3, 3) by forward kinematics."""
        return forward_kinematics(self.rotations, self.root_positions, self.skeleton.offsets,
                                  self.skeleton.parents, return_rotations=True,
                                  translations=self.translations)

    def sample(self, frame_times) -> "Motion":
        """The motion at fractional frame indices ``frame_times`` (n,), clamped to the clip:
        slerp for rotations, linear for the root and joint translations. The one resampler
        of the library (``resample`` and ``features.cycles.resample_uniform`` call it); the
        result keeps this motion's ``fps`` unless the caller replaces it."""
        t = np.clip(np.asarray(frame_times, dtype=np.float64), 0, self.n_frames - 1)
        i0 = np.minimum(np.floor(t).astype(int), self.n_frames - 1)
        i1 = np.minimum(i0 + 1, self.n_frames - 1)
        alpha = (t - i0)[:, None]

        def lerp(x):
            return x[i0] * (1 - alpha) + x[i1] * alpha
        rot = slerp_matrices(self.rotations[i0], self.rotations[i1], alpha)
        return replace(self, rotations=rot, root_positions=lerp(self.root_positions),
                       translations={j: lerp(v) for j, v in self.translations.items()},
                       meta=self._derived_meta())

    def resample(self, fps: float) -> "Motion":
        """Resample to ``fps`` over the same time span (see :meth:`sample`)."""
        n_new = int(np.floor(self.duration * fps + 1e-9)) + 1
        return replace(self.sample(np.arange(n_new) / fps * self.fps), fps=float(fps))

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
        trans = {j: self.translations[int(partner[j])] @ _MIRROR_X for j in range(sk.n_joints)
                 if int(partner[j]) in self.translations}
        return replace(self, skeleton=mirrored_sk, rotations=rot, root_positions=root, translations=trans,
                       name=self.name + "_mirror", meta=self._derived_meta())

    def rotated(self, matrix) -> "Motion":
        """The same motion seen in other world axes: every position p becomes ``matrix @ p``
        (a proper rotation, e.g. Z up -> Y up); FK of the result is FK of this one rotated."""
        a = np.asarray(matrix, dtype=np.float64)
        sk = self.skeleton
        ends = tuple((j, tuple(a @ np.asarray(off))) for j, off in sk.end_sites)
        meta = self._derived_meta()  # the file's raw values and OFFSETs are in the old axes
        meta.pop("root_offset", None)
        return replace(self, skeleton=Skeleton(sk.names, sk.parents, sk.offsets @ a.T, ends),
                       rotations=a @ self.rotations @ a.T, root_positions=self.root_positions @ a.T,
                       translations={j: t @ a.T for j, t in self.translations.items()}, meta=meta)

    def scaled(self, k: float) -> "Motion":
        """The motion ``k`` times as large about the world origin (offsets, end sites, root and
        joint translations; rotations unchanged): FK of the result is ``k`` times FK of this one.
        Per-frame arrays a reader kept (raw channel values) are dropped: they hold old lengths."""
        sk = self.skeleton
        ends = tuple((j, tuple(k * np.asarray(off))) for j, off in sk.end_sites)
        meta = self._derived_meta()
        if "root_offset" in meta:
            meta["root_offset"] = k * np.asarray(meta["root_offset"])
        return replace(self, skeleton=Skeleton(sk.names, sk.parents, k * sk.offsets, ends),
                       root_positions=k * self.root_positions,
                       translations={j: k * t for j, t in self.translations.items()}, meta=meta)

    def fold_root(self) -> "Motion":
        """Fold the root into its only child, which becomes the root (a reference node such
        as Bandai's ``joint_Root`` above ``Hips``). Exact: every other joint keeps its FK
        position; the folded root's own point is gone."""
        sk = self.skeleton
        kids = sk.children(0)
        if len(kids) != 1:
            raise ValueError(f"cannot fold root {sk.names[0]!r}: it has {len(kids)} children, not 1")
        c = kids[0]  # topological order: c == 1
        r0 = self.rotations[:, 0]
        local = self.translations.get(c, np.broadcast_to(sk.offsets[c], (self.n_frames, 3)))
        root = self.root_positions + sk.offsets[0] + (r0 @ local[..., None])[..., 0]
        rot = self.rotations[:, 1:].copy()
        rot[:, 0] = r0 @ self.rotations[:, c]
        offsets = sk.offsets[1:].copy()
        offsets[0] = 0.0  # the new root's place is root_positions
        parents = np.maximum(sk.parents[1:] - 1, -1)
        parents[0] = -1
        ends = tuple((j - 1, off) for j, off in sk.end_sites if j > 0)
        meta = self._derived_meta(keep_frames=True)
        meta["folded_root"] = sk.names[0]
        if "channels" in meta:  # the file's layout, minus the folded joint's channels
            n_root = len(meta["channels"][0])
            meta["channels"] = meta["channels"][1:]
            if "channel_values" in meta:
                meta["channel_values"] = meta["channel_values"][:, n_root:]
        meta["root_offset"] = sk.offsets[c]  # the new root's OFFSET, for writing the file back
        return replace(self, skeleton=Skeleton(sk.names[1:], parents, offsets, ends), rotations=rot,
                       root_positions=root, meta=meta,
                       translations={j - 1: t for j, t in self.translations.items() if j != c})

    def rigid(self, tolerance: float = 1e-3) -> "Motion":
        """The motion without per-frame joint translations, each replaced by the joint's rest
        offset. Raises ValueError if a translation strays more than ``tolerance`` metres from
        it (then the joint really moves, and dropping it would change the motion)."""
        sk = self.skeleton
        for j, t in self.translations.items():
            worst = float(np.abs(t - sk.offsets[j]).max())
            if worst > tolerance:
                raise ValueError(f"joint {sk.names[j]!r} moves {worst:.4f} m from its rest offset "
                                 f"(more than tolerance={tolerance} m); keep its translations")
        return replace(self, translations={}, meta=self._derived_meta(keep_frames=True))

    def keep_joints(self, names) -> "Motion":
        """Drop whole subtrees (e.g. hands); kept joints move exactly as before."""
        sub, idx = self.skeleton.keep_joints(names)
        meta = self._derived_meta()
        meta.pop("channels", None)  # the file's per-joint channel layout no longer applies
        new_index = {int(old): new for new, old in enumerate(idx)}
        trans = {new_index[j]: t for j, t in self.translations.items() if j in new_index}
        return replace(self, skeleton=sub, rotations=self.rotations[:, idx], translations=trans, meta=meta)

    def _derived_meta(self, frames: slice | None = None, keep_frames: bool = False) -> dict:
        """``meta`` for a motion made from this one. Per-frame arrays a reader kept (raw
        channel values, exp-maps) are sliced along with the frames, kept when the frames
        stay the same (``keep_frames``), or dropped when the frames themselves change
        (resampling, mirroring, dropping joints)."""
        def derive(meta: dict) -> dict:
            out = {}
            for key, value in meta.items():
                if isinstance(value, dict):
                    value = derive(value)
                elif isinstance(value, np.ndarray) and value.ndim and len(value) == self.n_frames:
                    if frames is None and not keep_frames:
                        continue
                    value = value if frames is None else value[frames]
                out[key] = value
            return out
        return derive(self.meta)
