"""A file's own skeleton mapped onto a model's joints (CCNet's 25), both ways.

A user's skeleton rarely has exactly the model's joints. With a joint map (file joint -> model
joint, :func:`mocapviz.skeleton.map_to_ccnet25`) the file's joints are of three kinds:

- **mapped**: the model joint takes the file joint's *global* rotation and position;
- **unmapped** (fingers, a reference root, a 3dsMax ``Chest3`` between two mapped spine
  joints): each keeps one fixed local rotation and translation, its mean over the reference
  motion. A model bone that spans such joints is their composed chain, so it keeps its length
  and shape whatever the model does;
- **missing** model joints (Bandai has no ``LHipJoint``, ``LowerBack``, ``Neck1``): made up as
  a joint that takes the whole file bone to its one model child, the child sitting at zero
  offset below it. The made-up joint's rotation then moves nothing (its only child is at its
  own position), so whatever the model writes there is lost without changing any position.

So the mapping back (:meth:`ModelRig.from_model`) is exact: forward kinematics of the file
skeleton at the mapped joints equals the model skeleton's joint positions. Why global, not
local rotations: when joints are dropped in between, the model joint's local rotation is the
product of the file's locals along the chain; matching global rotations carries it over
whatever the chain, with the dropped joints held fixed.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton, SkeletonMapError


def _mean_rotation(mats: np.ndarray) -> np.ndarray:
    """Mean (3, 3) of rotation matrices (F, 3, 3) (scipy's quaternion mean)."""
    return Rotation.from_matrix(mats).mean().as_matrix()


def _to_local(g: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """Local rotations (F, J, 3, 3) from global ones: L_j = G_parent^T G_j."""
    local = g.copy()
    local[:, 1:] = np.swapaxes(g[:, parents[1:]], -1, -2) @ g[:, 1:]
    return local


class ModelRig:
    """``reference``: a motion on the file's skeleton (its mean pose fixes the unmapped joints);
    ``joint_map``: file joint name -> model joint name; ``names``, ``parents``: the model's
    joint tree (topological order, root first)."""

    def __init__(self, reference: Motion, joint_map: dict[str, str], names, parents):
        sk = self.file_skeleton = reference.skeleton
        self.names, self.parents = tuple(names), np.asarray(parents, dtype=np.int64)
        by_model = {m: sk.index(f) for f, m in joint_map.items()}
        self.source = np.array([by_model.get(n, -1) for n in self.names])  # file joint of each model joint
        if self.source[0] < 0:
            raise SkeletonMapError(f"no file joint maps to the model's root {self.names[0]!r}")
        self.fixed_rot = np.array([_mean_rotation(reference.rotations[:, j]) for j in range(sk.n_joints)])
        self.fixed_trans = sk.offsets.copy()
        self.translated = sorted(reference.translations)  # joints with per-frame translations
        for j, t in reference.translations.items():
            self.fixed_trans[j] = t.mean(axis=0)
        self.skeleton = Skeleton(self.names, self.parents, *self._model_rest())

    def _chain(self, top: int, j: int) -> np.ndarray:
        """Vector (3,) from file joint ``top`` to its descendant ``j`` in ``top``'s frame, the
        joints between at their fixed rotation and translation."""
        mapped = set(self.source[self.source >= 0].tolist())
        v, k = self.fixed_trans[j], int(self.file_skeleton.parents[j])
        while k != top:
            if k < 0 or k in mapped:
                sk = self.file_skeleton
                raise SkeletonMapError(f"the joint map breaks the tree: {sk.names[j]!r} is not below "
                                       f"{sk.names[top]!r} without another mapped joint in between")
            v = self.fixed_trans[k] + self.fixed_rot[k] @ v
            k = int(self.file_skeleton.parents[k])
        return v

    def _model_rest(self):
        """Offsets (J, 3) and end sites of the model skeleton (see the module docstring)."""
        names, parents, src, fsk = self.names, self.parents, self.source, self.file_skeleton
        offsets = np.zeros((len(names), 3))
        kids = [np.flatnonzero(parents == c).tolist() for c in range(len(names))]
        ends = []
        for c in range(1, len(names)):
            if src[c] < 0:
                if len(kids[c]) > 1 or (not kids[c] and src[parents[c]] < 0):
                    raise SkeletonMapError(f"the file has no joint for {names[c]!r}, which cannot be made up "
                                           f"({len(kids[c])} children); map one with the explicit joint map")
                if not kids[c]:  # a missing leaf (a toe): at its parent's end site in the file
                    tips = [off for j, off in fsk.end_sites if j == src[parents[c]]]
                    if not tips:
                        raise SkeletonMapError(f"the file has no joint for {names[c]!r} and no end site "
                                               f"below {fsk.names[src[parents[c]]]!r} to put it at")
                    offsets[c] = tips[0]
                continue
            above = parents[c]
            while src[above] < 0:  # the nearest mapped model ancestor (the root is mapped)
                above = parents[above]
            top = c
            while parents[top] != above:  # the made-up joint right below it takes the whole bone
                top = parents[top]
            offsets[top] = self._chain(int(src[above]), int(src[c]))
            ends += [(c, off) for j, off in fsk.end_sites if j == src[c]]
            file_kids = fsk.children(int(src[c]))
            if file_kids and not kids[c]:  # children dropped (hands): an end site where the first was
                ends.append((c, tuple(self.fixed_trans[file_kids[0]])))
        return offsets, tuple(ends)

    def to_model(self, motion: Motion) -> Motion:
        """The model-skeleton motion (same frames) of a motion on the file's skeleton: mapped
        joints take their file joint's global rotation, made-up joints their parent's."""
        p, g = motion.global_pose()
        gm = np.empty((motion.n_frames, len(self.names), 3, 3))
        for c, s in enumerate(self.source):
            gm[:, c] = g[:, s] if s >= 0 else gm[:, self.parents[c]]
        return Motion(self.skeleton, _to_local(gm, self.parents), p[:, self.source[0]], motion.fps,
                      name=motion.name, meta={"source": motion.meta.get("source", "")})

    def from_model(self, motion: Motion) -> Motion:
        """The file-skeleton motion of a model-skeleton motion: exact at the mapped joints
        (global rotations and positions), the unmapped joints at their fixed pose."""
        pm, gm = motion.global_pose()
        fsk, n = self.file_skeleton, motion.n_frames
        g = np.empty((n, fsk.n_joints, 3, 3))
        p = np.empty((n, fsk.n_joints, 3))
        model_of = {int(s): c for c, s in enumerate(self.source) if s >= 0}
        root_src = int(self.source[0])
        if root_src != 0:  # unmapped joints above the model's root: placed so that it lands right
            g[:, 0] = self.fixed_rot[0]
            p[:, 0] = pm[:, 0] - self.fixed_rot[0] @ self._chain(0, root_src)
        for j in range(fsk.n_joints):
            if j in model_of:
                g[:, j], p[:, j] = gm[:, model_of[j]], pm[:, model_of[j]]
            elif j > 0:
                q = fsk.parents[j]
                g[:, j] = g[:, q] @ self.fixed_rot[j]
                p[:, j] = p[:, q] + g[:, q] @ self.fixed_trans[j]
        trans = {j: np.einsum("fji,fj->fi", g[:, fsk.parents[j]], p[:, j] - p[:, fsk.parents[j]])
                 for j in self.translated}
        return Motion(fsk, _to_local(g, fsk.parents), p[:, 0], motion.fps, name=motion.name, translations=trans)
