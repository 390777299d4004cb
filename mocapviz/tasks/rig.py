"""A file's own skeleton mapped onto a model's joints (CCNet's 25), both ways.

A user's skeleton rarely has exactly the model's joints. With a joint map (file joint -> model
joint, :func:`mocapviz.skeleton.map_to_ccnet25`) the file's joints are of three kinds:

- **mapped**: the model joint takes the file joint's *global* rotation and position;
- **unmapped** (fingers, a reference root, a 3dsMax ``Chest3`` between two mapped spine
  joints): each keeps one fixed local rotation and translation, its mean over the reference
  motion. A model bone that spans such joints is their composed chain, so it keeps its length
  and shape whatever the model does;
- **missing** model joints (Bandai has no ``LHipJoint``, ``LowerBack``, ``Neck1``): made up as
  the training data made them up (:func:`mocapviz.features.ccnet_joints.complete_ccnet25`, so
  that a seed reaches the network as the dataset built the same file): identity rotation, and
  either at zero length on their parent (``zero_length``: the hip stubs and LowerBack, the child
  taking the whole file bone) or halfway along the file bone (Neck1); a missing leaf (a toe) at
  its parent's end site. Positions of the mapped joints are unchanged.

Rest pose: a file's local rotations are relative to *its* rest pose (Bandai's lies along X,
Mixamo's stands straight-legged, CMU's splays the legs), and a model reads them as relative to
the rest pose of its training skeletons. Given that rest pose (``canonical_rest``, e.g. the
mean c^s of the training data), each mapped joint gets a constant alignment rotation A_c that
turns the model's rest directions of its bones onto the file's (a best fit, scipy's
``align_vectors``, where a joint has bones in several directions; the shortest arc after its
parent's alignment where it has one, so that twist is carried down the chain, then turned
about the bone by the twist that brings the reference motion's rotations nearest the
training statistics when those are given, since a straight rest bone cannot show its twist;
its parent's where it has none). A skeleton the training data had (Bandai's) can instead be
given the alignment its dataset used (``alignment``: model joint -> the A of
:func:`mocapviz.features.ccnet_joints.rest_alignment`), so that its frame vectors are exactly the
dataset's. The model joint's global rotation is then the file joint's times A_c, and
the model skeleton's offsets are the file's bones turned by A_c^T: the file's bone lengths in
the training skeletons' rest directions, which is what c^s shows the model.

So the mapping back (:meth:`ModelRig.from_model`) is exact: forward kinematics of the file
skeleton at the mapped joints equals the model skeleton's joint positions. Why global, not
local rotations: when joints are dropped in between, the model joint's local rotation is the
product of the file's locals along the chain; matching global rotations carries it over
whatever the chain, with the dropped joints held fixed.

Two model skeletons share that rest convention, so a motion moves between them by its local
rotations, the hip joints' midpoint and leg IK (:func:`retarget_to`): the generate command
generates any body but the training body on the training body the repository knows
(:func:`known_body`) and brings the result back.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from mocapviz.features.ccnet_joints import CCNET_25_PARENTS, KNOWN_RESTS_FILE, ZERO_LENGTH_JOINTS
from mocapviz.heading import shortest_arc
from mocapviz.ik import LEGS, two_bone_ik
from mocapviz.kinematics import global_to_local
from mocapviz.motion import Motion
from mocapviz.rotations import matrix_to_rotvec
from mocapviz.skeleton import Skeleton, SkeletonMapError


def _mean_rotation(mats: np.ndarray) -> np.ndarray:
    """Mean (3, 3) of rotation matrices (F, 3, 3) (scipy's quaternion mean)."""
    return Rotation.from_matrix(mats).mean().as_matrix()


class ModelRig:
    """``reference``: a motion on the file's skeleton (its mean pose fixes the unmapped joints);
    ``joint_map``: file joint name -> model joint name; ``names``, ``parents``: the model's
    joint tree (topological order, root first); ``canonical_rest`` (J, 3): the model's rest
    joint positions (metres, root at the origin) that the file's rest is aligned to (None:
    the file's own rest pose, no alignment); ``alignment``: model joint name -> (3, 3) rest
    re-basing of its file joint as :func:`mocapviz.features.ccnet_joints.rest_alignment` gives it
    (instead of ``canonical_rest``); ``rotation_stats``: the model's training mean and standard
    deviation (J, 3) of each joint's local exp map: with them a joint aligned along one bone gets
    the twist about that bone (which a rest pose cannot show) that brings the reference motion's
    local rotations closest to training (z-scores, greedily from the root down);
    ``zero_length``: model joints that, made up, sit on their parent (the rest halfway along
    the file bone)."""

    def __init__(self, reference: Motion, joint_map: dict[str, str], names, parents, canonical_rest=None,
                 rotation_stats=None, alignment: dict | None = None, zero_length=ZERO_LENGTH_JOINTS):
        sk = self.file_skeleton = reference.skeleton
        self.names, self.parents = tuple(names), np.asarray(parents, dtype=np.int64)
        by_model = {m: sk.index(f) for f, m in joint_map.items()}
        self.source = np.array([by_model.get(n, -1) for n in self.names])  # file joint of each model joint
        if self.source[0] < 0:
            raise SkeletonMapError(f"no file joint maps to the model's root {self.names[0]!r}")
        self.fixed_rot = np.array([_mean_rotation(reference.rotations[:, j]) for j in range(sk.n_joints)])
        self.fixed_trans = sk.offsets.copy()
        self.translated = sorted(reference.translations)  # joints with per-frame translations
        self.fixed_root = reference.root_positions.mean(axis=0)  # where an unmapped reference root stays
        for j, t in reference.translations.items():
            self.fixed_trans[j] = t.mean(axis=0)
        identity = np.broadcast_to(np.eye(3), (len(self.names), 3, 3))
        self.stats = None if rotation_stats is None else [np.asarray(a, dtype=np.float64) for a in rotation_stats]
        self.zero_length = set(zero_length)
        self.align = identity.copy()  # A_c per model joint
        if alignment is not None:  # rebase_rest's A maps the file's rest frames onto the model's: A_c = A^T
            for c, name in enumerate(self.names):
                if self.source[c] >= 0:
                    self.align[c] = np.asarray(alignment[name], dtype=np.float64).reshape(3, 3).T
            for c in range(1, len(self.names)):  # made-up joints turn with their parent
                if self.source[c] < 0:
                    self.align[c] = self.align[self.parents[c]]
        elif canonical_rest is not None:
            self.align = self._alignments(np.asarray(canonical_rest, dtype=np.float64), reference)
        # a body the training data did not have: its rest turned onto the training skeletons' rest
        self.aligned_to_canonical = alignment is None and canonical_rest is not None
        self.skeleton = Skeleton(self.names, self.parents, *self._model_rest())

    def _chain(self, top: int, j: int) -> np.ndarray:
        """Vector (3,) from file joint ``top`` to its descendant ``j`` in ``top``'s frame, the
        joints between at their fixed rotation and translation."""
        return self._chain_pose(top, j)[0]

    def _chain_pose(self, top: int, j: int) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_chain` and the rotation (3, 3) of ``j``'s parent frame in ``top``'s frame."""
        mapped = set(self.source[self.source >= 0].tolist())
        v, k, rot = self.fixed_trans[j], int(self.file_skeleton.parents[j]), np.eye(3)
        while k != top:
            if k < 0 or k in mapped:
                sk = self.file_skeleton
                raise SkeletonMapError(f"the joint map breaks the tree: {sk.names[j]!r} is not below "
                                       f"{sk.names[top]!r} without another mapped joint in between")
            v = self.fixed_trans[k] + self.fixed_rot[k] @ v
            rot = self.fixed_rot[k] @ rot
            k = int(self.file_skeleton.parents[k])
        return v, rot

    def _nearest_mapped_above(self, c: int) -> int:
        above = self.parents[c]
        while self.source[above] < 0:  # the root is mapped
            above = self.parents[above]
        return int(above)

    def _file_rest(self) -> tuple[np.ndarray, np.ndarray]:
        """Rest positions (J, 3) of the model joints on the file's skeleton (mapped joints at
        identity, the others fixed; made-up joints where they sit, see :meth:`_model_rest`),
        and the rest frames (J, 3, 3) of the mapped ones, in the model root's frame."""
        n, src = len(self.names), self.source
        pos, frame = np.zeros((n, 3)), np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        for c in range(1, n):
            if src[c] >= 0:
                a = self._nearest_mapped_above(c)
                v, rot = self._chain_pose(int(src[a]), int(src[c]))
                pos[c], frame[c] = pos[a] + frame[a] @ v, frame[a] @ rot
        for c in range(n - 1, 0, -1):  # made-up joints: on their parent, halfway, or (a leaf) at its end site
            if src[c] < 0:
                kids, up = np.flatnonzero(self.parents == c), pos[self.parents[c]]
                pos[c] = (up if self.names[c] in self.zero_length else (up + pos[kids[0]]) / 2) if len(kids) \
                    else up + frame[self.parents[c]] @ self._tip(c)
        return pos, frame

    def _alignments(self, canonical: np.ndarray, reference: Motion) -> np.ndarray:
        """A_c (J, 3, 3): model rest directions -> the file's, per mapped joint (module docstring)."""
        n, src = len(self.names), self.source
        pos, frame = self._file_rest()
        file_global = reference.global_pose()[1]
        model_global = np.empty((reference.n_frames, n, 3, 3))  # G'_c of the reference, as A_c are chosen
        kids = [np.flatnonzero(self.parents == c) for c in range(n)]
        align = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        for c in range(n):
            base = align[self.parents[c]] if c else np.eye(3)
            if src[c] < 0:
                align[c] = base
                model_global[:, c] = model_global[:, self.parents[c]]
                continue
            model_dirs, file_dirs = [], []
            for k in kids[c]:  # each bone's direction: the first joint down its chain 5 cm away
                d = int(k)
                while (np.linalg.norm(canonical[d] - canonical[c]) < 0.05
                       or np.linalg.norm(pos[d] - pos[c]) < 0.05) and len(kids[d]):
                    d = int(kids[d][0])
                m, f = canonical[d] - canonical[c], frame[c].T @ (pos[d] - pos[c])
                if np.linalg.norm(m) > 1e-6 and np.linalg.norm(f) > 1e-6:
                    model_dirs.append(m / np.linalg.norm(m))
                    file_dirs.append(f / np.linalg.norm(f))
            spread = max((np.linalg.norm(np.cross(a, b)) for a in model_dirs for b in model_dirs), default=0.0)
            if spread > 0.2:  # bones in several directions (hips): the best-fitting rotation
                align[c] = Rotation.align_vectors(np.array(file_dirs), np.array(model_dirs))[0].as_matrix()
            elif model_dirs:  # one direction: the shortest arc after the parent's alignment
                m, f = np.mean(model_dirs, axis=0), np.mean(file_dirs, axis=0)
                align[c] = shortest_arc(base @ m, f) @ base
                if self.stats is not None and c > 0:
                    align[c] = align[c] @ self._best_twist(c, m, model_global[:, self.parents[c]],
                                                           file_global[:, src[c]] @ align[c])
            else:
                align[c] = base
            model_global[:, c] = file_global[:, src[c]] @ align[c]
        return align

    def _best_twist(self, c: int, axis: np.ndarray, parent_global: np.ndarray, global_rot: np.ndarray,
                    steps: int = 72) -> np.ndarray:
        """Rotation (3, 3) about the model bone ``axis`` (a twist that keeps the bone's
        direction) whose local rotations parent^T global twist lie nearest the training mean,
        in z-scores, over the reference frames; a grid of ``steps`` angles."""
        twists = Rotation.from_rotvec(np.outer(np.arange(steps) * 2 * np.pi / steps, axis)).as_matrix()
        local = np.swapaxes(parent_global, -1, -2) @ global_rot                     # (F, 3, 3)
        cand = matrix_to_rotvec(local[None] @ twists[:, None])                     # (steps, F, 3)
        mean, std = self.stats[0][c], np.maximum(self.stats[1][c], 1e-3)
        score = (((cand - mean) / std) ** 2).sum(-1).mean(-1)
        return twists[int(np.argmin(score))]

    def _tip(self, c: int) -> np.ndarray:
        """A missing leaf's offset in its mapped parent's file frame: the parent's end site."""
        fsk, p = self.file_skeleton, int(self.source[self.parents[c]])
        tips = [off for j, off in fsk.end_sites if j == p]
        if p < 0 or not tips:
            raise SkeletonMapError(f"the file has no joint for {self.names[c]!r} and no end site to put it at")
        return np.asarray(tips[0], dtype=np.float64)

    def _model_rest(self):
        """Offsets (J, 3) and end sites of the model skeleton: the file's bones turned by the
        alignment A^T; the file bone through a made-up joint goes to its one model child (on a
        ``zero_length`` joint) or half to each (module docstring)."""
        names, parents, src, fsk, align = self.names, self.parents, self.source, self.file_skeleton, self.align
        offsets = np.zeros((len(names), 3))
        kids = [np.flatnonzero(parents == c).tolist() for c in range(len(names))]
        ends = []
        for c in range(1, len(names)):
            if src[c] < 0:
                if len(kids[c]) > 1 or (not kids[c] and src[parents[c]] < 0):
                    raise SkeletonMapError(f"the file has no joint for {names[c]!r}, which cannot be made up "
                                           f"({len(kids[c])} children); map one with the explicit joint map")
                if not kids[c]:  # a missing leaf (a toe): at its parent's end site in the file
                    offsets[c] = align[parents[c]].T @ self._tip(c)
                continue
            above = self._nearest_mapped_above(c)
            bone = align[above].T @ self._chain(int(src[above]), int(src[c]))
            between, j = [], int(parents[c])
            while j != above:  # made-up joints in between, each with this one child
                between.append(j)
                j = int(parents[j])
            takers = [j for j in between if names[j] not in self.zero_length] + [c]
            for j in takers:  # equal shares of the bone (Neck1 and Head: half each)
                offsets[j] = bone / len(takers)
            ends += [(c, tuple(align[c].T @ np.asarray(off))) for j, off in fsk.end_sites if j == src[c]]
            file_kids = fsk.children(int(src[c]))
            if file_kids and not kids[c]:  # children dropped (hands): an end site where the first was
                ends.append((c, tuple(align[c].T @ self.fixed_trans[file_kids[0]])))
        return offsets, tuple(ends)

    def to_model(self, motion: Motion) -> Motion:
        """The model-skeleton motion (same frames) of a motion on the file's skeleton: mapped
        joints take their file joint's global rotation (times A_c), made-up joints their
        parent's."""
        p, g = motion.global_pose()
        gm = np.empty((motion.n_frames, len(self.names), 3, 3))
        for c, s in enumerate(self.source):
            gm[:, c] = g[:, s] @ self.align[c] if s >= 0 else gm[:, self.parents[c]]
        return Motion(self.skeleton, global_to_local(gm, self.parents), p[:, self.source[0]], motion.fps,
                      name=motion.name, meta={"source": motion.meta.get("source", "")})

    def expressible(self, motion: Motion) -> Motion:
        """A model-skeleton motion with the made-up joints' local rotations at identity: the
        file has no joint to carry them (with them, FK of the file would miss the model's
        joints by up to ~1 cm at a made-up neck), and identity is what the training data of
        such skeletons had (:func:`mocapviz.features.ccnet_joints.complete_ccnet25`)."""
        rot = motion.rotations.copy()
        rot[:, self.source < 0] = np.eye(3)
        return Motion(motion.skeleton, rot, motion.root_positions, motion.fps, name=motion.name,
                      meta=dict(motion.meta))

    def from_model(self, motion: Motion) -> Motion:
        """The file-skeleton motion of a model-skeleton motion: exact at the mapped joints
        (global rotations and positions), the unmapped joints at their fixed pose."""
        pm, gm = motion.global_pose()
        fsk, n = self.file_skeleton, motion.n_frames
        g = np.empty((n, fsk.n_joints, 3, 3))
        p = np.empty((n, fsk.n_joints, 3))
        model_of = {int(s): c for c, s in enumerate(self.source) if s >= 0}
        root_src = int(self.source[0])
        if root_src != 0:  # unmapped joints above the model's root (a reference root, as in Bandai)
            g[:, 0] = self.fixed_rot[0]
            if root_src in self.translated:  # the file moves its body root: the reference root stays put
                p[:, 0] = self.fixed_root
            else:  # only the file's root can travel: placed so that the body root lands right
                p[:, 0] = pm[:, 0] - self.fixed_rot[0] @ self._chain(0, root_src)
        for j in range(fsk.n_joints):
            if j in model_of:
                c = model_of[j]
                g[:, j], p[:, j] = gm[:, c] @ self.align[c].T, pm[:, c]
            elif j > 0:
                q = fsk.parents[j]
                g[:, j] = g[:, q] @ self.fixed_rot[j]
                p[:, j] = p[:, q] + g[:, q] @ self.fixed_trans[j]
        trans = {j: np.einsum("fji,fj->fi", g[:, fsk.parents[j]], p[:, j] - p[:, fsk.parents[j]])
                 for j in self.translated}
        return Motion(fsk, global_to_local(g, fsk.parents), p[:, 0], motion.fps, name=motion.name, translations=trans)


def leg_length(skeleton: Skeleton, legs=LEGS) -> float:
    """Mean over the legs of thigh plus shin length (m): hip joint to knee to ankle."""
    return float(np.mean([np.linalg.norm(skeleton.offsets[skeleton.index(knee)])
                          + np.linalg.norm(skeleton.offsets[skeleton.index(ankle)]) for _, knee, ankle in legs]))


def hip_midpoint(skeleton: Skeleton, positions: np.ndarray, legs=LEGS) -> np.ndarray:
    """(..., 3) midpoint of the two hip joints (the legs' first joints) of positions (..., J, 3)."""
    return 0.5 * (positions[..., skeleton.index(legs[0][0]), :] + positions[..., skeleton.index(legs[1][0]), :])


def retarget_to(motion: Motion, target: Skeleton, ik: bool = True, legs=LEGS) -> Motion:
    """``motion`` (on the model's joints) on ``target``, a skeleton of the same joints and the
    same rest convention (two model skeletons: a :class:`ModelRig`'s and :func:`known_body`'s,
    both resting in the training skeletons' bone directions, with other bone lengths). The
    local rotations carry over as they are; the root is placed so that the midpoint of the hip
    joints follows ``motion``'s (the root sits at another height above the hips in each rig: a
    Mixamo ``Hips`` 7 cm, Bandai's 2 cm, a VICON root about 10 cm); with ``ik``, two-bone IK
    (:func:`mocapviz.ik.two_bone_ik`) bends hips and knees so that the ankles land on
    ``motion``'s, so that a planted foot stays planted when the two bodies' thighs and shins
    differ (scale ``motion`` to ``target``'s leg length first: a leg too short for its target
    ends straight, pointing at it).

    Why the local rotations as they are, not world orientations through a rest alignment
    (:func:`mocapviz.bodies.retarget.rest_alignment`): the two rests differ by at most 3
    degrees at a joint with a bone (a Mixamo body aligned to the mean training rest against
    the Bandai body; spine under 1 degree), so the rotations mean the same pose on both, the
    mapping is its own inverse, and made-up joints keep the identity the file cannot carry
    (:meth:`ModelRig.expressible`); through the alignment, the made-up hip stubs took an
    18-degree turn that writing the file then dropped, and a pelvis whose hip joints lie level
    with the root (Xsens) left the hips' alignment undefined."""
    src_pos = motion.positions()
    at_origin = Motion(target, motion.rotations, np.zeros((motion.n_frames, 3)), motion.fps).positions()
    root = hip_midpoint(motion.skeleton, src_pos, legs) - hip_midpoint(target, at_origin, legs)
    out = Motion(target, motion.rotations, root, motion.fps, name=motion.name, meta=dict(motion.meta))
    if not ik:
        return out
    pos, glob = out.global_pose()
    targets = {ankle: src_pos[:, motion.skeleton.index(ankle)] for _, _, ankle in legs}
    rot = global_to_local(two_bone_ik(glob, pos, target, targets, legs), target.parents)
    return Motion(target, rot, root, motion.fps, name=motion.name, meta=dict(motion.meta))


def known_body(names, parents, which: str = "bandai", path=KNOWN_RESTS_FILE) -> Skeleton:
    """The model skeleton (``names``, ``parents``: the model's joint tree) of a training body
    the repository knows (``known_rests.json``, written by ``python -m data_prep known-rests``:
    the file offsets and the dataset's rest re-basing of Bandai's skeleton), built as the
    dataset built it (:class:`ModelRig` with that re-basing, missing joints made up): the
    body of 90 % of the training frames, whose c^s lies 0.5 training standard deviations
    (root mean square) from the training mean (the VICON skeletons: 1.8-3.3)."""
    entry = json.loads(path.read_text())[which]
    offsets = entry["offsets"]
    file_names = [names[0]] + [n for n in names[1:] if n in offsets]

    def present_parent(n):
        p = CCNET_25_PARENTS[n]
        while p not in file_names:
            p = CCNET_25_PARENTS[p]
        return file_names.index(p)
    file_sk = Skeleton(tuple(file_names), np.array([-1] + [present_parent(n) for n in file_names[1:]]),
                       np.array([np.zeros(3)] + [offsets[n] for n in file_names[1:]], dtype=np.float64), ())
    rest = Motion(file_sk, np.broadcast_to(np.eye(3), (1, len(file_names), 3, 3)).copy(), np.zeros((1, 3)), 60.0)
    alignment = {m: np.asarray(a, dtype=np.float64).reshape(3, 3) for m, a in entry["alignment"].items()}
    return ModelRig(rest, {n: n for n in file_names}, names, parents, alignment=alignment).skeleton


def floor_height(positions: np.ndarray) -> float:
    """The floor (m) under frames of joint positions (F, J, 3), Y up: the median over frames of
    the lowest joint's height (a planted toe or heel)."""
    return float(np.median(positions[..., 1].min(axis=-1)))


def grounded(motion: Motion, floor: float, seconds: float = 1.0) -> Motion:
    """``motion`` raised or lowered, frame by frame, so that the running median over ``seconds``
    of its lowest joint's height stays at ``floor`` (m), the correction smoothed over as long
    again (a step's heel-toe roll and a hop's flight do not move it)."""
    low = motion.positions()[..., 1].min(axis=-1)
    n = max(1, int(round(seconds * motion.fps)))
    pad = np.pad(low, (n // 2, n - 1 - n // 2), mode="edge")
    running = np.median(np.lib.stride_tricks.sliding_window_view(pad, n), axis=-1)
    shift = np.convolve(np.pad(floor - running, (n // 2, n - 1 - n // 2), mode="edge"), np.ones(n) / n, mode="valid")
    root = motion.root_positions.copy()
    root[:, 1] += shift
    return replace(motion, root_positions=root, meta={**motion.meta, "grounded_shift": shift})
