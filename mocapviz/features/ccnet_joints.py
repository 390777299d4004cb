"""Any source's skeleton onto CCNet's 25 joints with one rest-pose convention.

CCNet's frame vector holds *local* rotations, so they mean the same thing for every source
only if every skeleton's rest pose (all rotations identity) is the same kind of pose with
world-aligned joint frames. HDM05 and CMU rest in the VICON T-pose facing +Z (Y up, left = +X,
legs splayed 20 degrees) with identity joint frames. Bandai's rest pose is a rig pose (every bone along its parent's
local +-X, the body folded flat), so its rotations are ~90 degrees off everywhere, and it lacks
four of the 25 joints. Two steps fix that, both leaving every FK joint position unchanged:

* :func:`rest_alignment` + :func:`rebase_rest`: constant per-joint frame changes ``A_j``
  (``G'_j = G_j A_j^T``, ``L'_j = A_parent L_j A_j^T``, offsets ``A_parent o_j``) that make a
  given reference frame of the motion, straightened into the VICON rest pose of
  :data:`T_POSE_DIRECTIONS`, the new rest pose. The reference frame fixes each bone's twist
  (which way an elbow bends), which bone directions alone cannot.
* :func:`complete_ccnet25`: joints of the 25 a skeleton lacks are inserted with identity
  rotations: the hip stubs and LowerBack at their parent (zero length, as in every VICON tree),
  any other (Bandai's Neck1) halfway along its parent's bone to its child; joints come out in
  :data:`CCNET_25_JOINTS` order.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from mocapviz.heading import shortest_arc
from mocapviz.motion import Motion
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton

# Parent of each of the 25 joints in the VICON tree (CMU BVH names).
CCNET_25_PARENTS = {
    "Hips": None, "LHipJoint": "Hips", "LeftUpLeg": "LHipJoint", "LeftLeg": "LeftUpLeg",
    "LeftFoot": "LeftLeg", "LeftToeBase": "LeftFoot", "RHipJoint": "Hips", "RightUpLeg": "RHipJoint",
    "RightLeg": "RightUpLeg", "RightFoot": "RightLeg", "RightToeBase": "RightFoot",
    "LowerBack": "Hips", "Spine": "LowerBack", "Spine1": "Spine", "Neck": "Spine1", "Neck1": "Neck",
    "Head": "Neck1", "LeftShoulder": "Spine1", "LeftArm": "LeftShoulder", "LeftForeArm": "LeftArm",
    "LeftHand": "LeftForeArm", "RightShoulder": "Spine1", "RightArm": "RightShoulder",
    "RightForeArm": "RightArm", "RightHand": "RightForeArm",
}
# Zero-length joints in every VICON tree: inserted at their parent.
ZERO_LENGTH_JOINTS = ("LHipJoint", "RHipJoint", "LowerBack")
# Bone directions (joint -> child) of the rest pose re-based skeletons take (facing +Z, Y up,
# left = +X): the VICON rest of every HDM05 and CMU skeleton here, so that a local rotation
# poses a limb alike in every source: thighs and shins splayed 20 degrees out, spine and neck
# up, clavicles and arms straight out. Feet are not straightened (like hands, head and toes,
# they keep their reference orientation relative to the shin): the toe joint sits elsewhere in
# each rig (Bandai's foot bone points 40 degrees down when it stands flat, CMU's ~18), and so
# standing flat stays a near-identity ankle rotation, as in HDM05 and CMU.
_SPLAY = np.radians(20.0)
T_POSE_DIRECTIONS = {
    **{f"Left{j}": (np.sin(_SPLAY), -np.cos(_SPLAY), 0.0) for j in ("UpLeg", "Leg")},
    **{f"Right{j}": (-np.sin(_SPLAY), -np.cos(_SPLAY), 0.0) for j in ("UpLeg", "Leg")},
    **{j: (0.0, 1.0, 0.0) for j in ("LowerBack", "Spine", "Neck", "Neck1")},
    **{f"Left{j}": (1.0, 0.0, 0.0) for j in ("Shoulder", "Arm", "ForeArm")},
    **{f"Right{j}": (-1.0, 0.0, 0.0) for j in ("Shoulder", "Arm", "ForeArm")},
}
# Joints with several children: their frame is set by an up bone and a left-right vector.
_FRAME_JOINTS = {"Hips": ("Spine", ("LeftUpLeg", "RightUpLeg")),
                 "Spine1": ("Neck", ("LeftShoulder", "RightShoulder"))}


def _frame(up: np.ndarray, across: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) whose columns are the orthonormalised across (X), up (Y), forward (Z)."""
    y = up / np.linalg.norm(up)
    x = across - (across @ y) * y
    x /= np.linalg.norm(x)
    return np.stack([x, y, np.cross(x, y)], axis=1)


def _first_child(skeleton: Skeleton, j: int) -> int | None:
    """The child of j along its CCNet bone (the one named in the 25-joint tree), else None."""
    kids = [c for c in skeleton.children(j) if np.linalg.norm(skeleton.offsets[c]) > 1e-6]
    return kids[0] if len(kids) == 1 else None


def rest_alignment(skeleton: Skeleton, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """Per-joint frame changes ``A`` (J, 3, 3) that make one reference frame (global joint
    ``positions`` (J, 3) m and ``rotations`` (J, 3, 3), e.g. a standing frame) the rest pose,
    straightened into :data:`T_POSE_DIRECTIONS` by the smallest rotation per bone.

    The pelvis frame (spine up, hips across) is turned onto the world axes first, so that the
    reference frame's heading does not matter. Joints without a direction there (feet, hands,
    head, toes) keep their reference orientation relative to their parent.
    """
    names = skeleton.names
    hips_up, (l, r) = _FRAME_JOINTS["Hips"]
    face = _frame(positions[names.index(hips_up)] - positions[0],
                  positions[names.index(l)] - positions[names.index(r)]).T  # pelvis -> world axes
    pos, glob = positions @ face.T, face @ rotations
    corr = np.zeros((len(names), 3, 3))
    for j, name in enumerate(names):
        if name in _FRAME_JOINTS:
            up, (l, r) = _FRAME_JOINTS[name]
            corr[j] = _frame(pos[names.index(up)] - pos[j], pos[names.index(l)] - pos[names.index(r)]).T
        elif name in T_POSE_DIRECTIONS and _first_child(skeleton, j) is not None:
            corr[j] = shortest_arc(pos[_first_child(skeleton, j)] - pos[j], np.array(T_POSE_DIRECTIONS[name]))
        else:
            corr[j] = corr[skeleton.parents[j]]
    return corr @ glob


def rebase_rest(motion: Motion, alignment: np.ndarray) -> Motion:
    """The same motion (identical FK positions) on the rest pose of ``alignment`` (J, 3, 3)
    from :func:`rest_alignment`. Rigid motions only (no per-joint translations)."""
    if motion.translations:
        raise ValueError("rebase_rest needs a rigid motion (call Motion.rigid first)")
    sk, a = motion.skeleton, np.asarray(alignment, dtype=np.float64)
    parent_a = np.stack([a[p] if p >= 0 else np.eye(3) for p in sk.parents])
    offsets = (parent_a @ sk.offsets[..., None])[..., 0]
    offsets[0] = sk.offsets[0]  # the root's offset is in world axes
    ends = tuple((j, tuple(a[j] @ np.asarray(off))) for j, off in sk.end_sites)
    rot = parent_a @ motion.rotations @ np.swapaxes(a, -1, -2)
    return replace(motion, skeleton=Skeleton(sk.names, sk.parents, offsets, ends), rotations=rot,
                   meta=motion._derived_meta())


def complete_ccnet25(motion: Motion) -> Motion:
    """The motion on exactly :data:`CCNET_25_JOINTS` (in that order), lacking joints inserted
    with identity rotations (see the module docstring); every present joint's FK position is
    unchanged. Its joints must be a subset of the 25, each under its nearest present ancestor."""
    sk = motion.skeleton
    extra = set(sk.names) - set(CCNET_25_JOINTS)
    if extra or motion.translations:
        raise ValueError(f"complete_ccnet25 needs a rigid motion on a subset of the 25 joints; "
                         f"extra joints: {sorted(extra)}")

    def present_ancestor(name):
        p = CCNET_25_PARENTS[name]
        return p if p is None or p in sk.names else present_ancestor(p)
    for name in sk.names:
        want, got = present_ancestor(name), sk.parents[sk.index(name)]
        if (want is None) != (got < 0) or (want is not None and sk.names[got] != want):
            raise ValueError(f"joint {name!r} hangs under {sk.names[got] if got >= 0 else None!r}, "
                             f"not under {want!r} as in the 25-joint tree")
    n_f, order = motion.n_frames, list(CCNET_25_JOINTS)
    rot = np.broadcast_to(np.eye(3), (n_f, len(order), 3, 3)).copy()
    offsets = np.zeros((len(order), 3))
    for i, name in enumerate(order):
        if name in sk.names:
            rot[:, i] = motion.rotations[:, sk.index(name)]
            offsets[i] = sk.offsets[sk.index(name)]
    for name in order:  # a missing joint off the zero-length list takes half of its child's bone
        if name not in sk.names and name not in ZERO_LENGTH_JOINTS:
            child = order.index(next(c for c, p in CCNET_25_PARENTS.items() if p == name))
            offsets[child] /= 2.0
            offsets[order.index(name)] = offsets[child]
    parents = np.array([-1 if CCNET_25_PARENTS[n] is None else order.index(CCNET_25_PARENTS[n]) for n in order])
    ends = tuple((order.index(sk.names[j]), off) for j, off in sk.end_sites)
    meta = motion._derived_meta()
    meta.pop("channels", None)
    return replace(motion, skeleton=Skeleton(tuple(order), parents, offsets, ends), rotations=rot, meta=meta)


# The rest re-basings the training data used for skeletons that are not VICON's (Bandai's), so
# that a user's file on such a skeleton reaches a model exactly as the dataset built it:
# written by ``python -m data_prep known-rests`` from the data (a few numbers per joint).
KNOWN_RESTS_FILE = Path(__file__).with_name("known_rests.json")


def known_alignment(skeleton: Skeleton, joint_map: dict[str, str], tol: float = 0.01,
                    path: Path = KNOWN_RESTS_FILE) -> dict[str, np.ndarray] | None:
    """Model joint -> (3, 3) rest re-basing A (:func:`rest_alignment`) of a known training
    skeleton whose mapped joints' offsets (metres, the root's excepted) match ``skeleton``'s
    (file joint -> model joint ``joint_map``) within ``tol`` (Bandai's takes differ by up to
    0.4 mm in a bone; the dataset re-bases them all alike); None for any other skeleton."""
    if not path.is_file():
        return None
    offsets = {m: skeleton.offsets[skeleton.index(f)] for f, m in joint_map.items() if m != "Hips"}
    for entry in json.loads(path.read_text()).values():
        known = entry["offsets"]
        if set(known) == set(offsets) and all(np.abs(np.asarray(known[m]) - offsets[m]).max() <= tol for m in known):
            return {m: np.asarray(a, dtype=np.float64).reshape(3, 3) for m, a in entry["alignment"].items()}
    return None
