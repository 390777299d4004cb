"""Skeleton: joint names, parents and rest offsets (metres, Y up), plus topology maps."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# The 31-joint VICON tree of CMU and HDM05, in the names of the CMU BVH conversion (Hahne),
# and the ASF bone that drives each joint (the joint sits where that bone starts).
VICON_BVH_TO_ASF = {
    "Hips": "root",
    "LHipJoint": "lhipjoint", "LeftUpLeg": "lfemur", "LeftLeg": "ltibia",
    "LeftFoot": "lfoot", "LeftToeBase": "ltoes",
    "RHipJoint": "rhipjoint", "RightUpLeg": "rfemur", "RightLeg": "rtibia",
    "RightFoot": "rfoot", "RightToeBase": "rtoes",
    "LowerBack": "lowerback", "Spine": "upperback", "Spine1": "thorax",
    "Neck": "lowerneck", "Neck1": "upperneck", "Head": "head",
    "LeftShoulder": "lclavicle", "LeftArm": "lhumerus", "LeftForeArm": "lradius",
    "LeftHand": "lwrist", "LeftFingerBase": "lhand", "LeftHandIndex1": "lfingers",
    "LThumb": "lthumb",
    "RightShoulder": "rclavicle", "RightArm": "rhumerus", "RightForeArm": "rradius",
    "RightHand": "rwrist", "RightFingerBase": "rhand", "RightHandIndex1": "rfingers",
    "RThumb": "rthumb",
}
ASF_TO_VICON_BVH = {v: k for k, v in VICON_BVH_TO_ASF.items()}

# The 25 joints CCNet models: the VICON tree without hands, fingers and thumbs.
VICON_HAND_JOINTS = (
    "LeftFingerBase", "LeftHandIndex1", "LThumb",
    "RightFingerBase", "RightHandIndex1", "RThumb",
)
CCNET_25_JOINTS = tuple(n for n in VICON_BVH_TO_ASF if n not in VICON_HAND_JOINTS)



def _both_sides(left: dict[str, str], right_of) -> dict[str, str]:
    """A left-side name table plus its right side (``right_of`` turns a left name right)."""
    out = dict(left)
    for name, target in left.items():
        if "Left" in target:
            out[right_of(name)] = target.replace("Left", "Right")
    return out


# File joint names of the conventions real files use -> the CCNet 25-joint (CMU BVH) names,
# and the names each convention has that the 25 joints leave out (fingers, end joints, a
# reference root, an extra spine joint). Joints of neither kind cannot be placed.
NAME_CONVENTIONS: dict[str, dict[str, str]] = {
    "cmu_motionbuilder": {n: n for n in CCNET_25_JOINTS},  # Hahne's MotionBuilder-friendly BVH
    "vicon_asf": {a: b for a, b in ASF_TO_VICON_BVH.items() if b in CCNET_25_JOINTS},  # CMU/HDM05 ASF
    "cmu_3dsmax": _both_sides({  # 3dsMax-friendly CMU BVH (also Xsens-style exports)
        "Hips": "Hips", "Chest": "LowerBack", "Chest2": "Spine", "Chest4": "Spine1", "Neck": "Neck",
        "Head": "Head", "LeftCollar": "LeftShoulder", "LeftShoulder": "LeftArm", "LeftElbow": "LeftForeArm",
        "LeftWrist": "LeftHand", "LeftHip": "LeftUpLeg", "LeftKnee": "LeftLeg", "LeftAnkle": "LeftFoot",
        "LeftToe": "LeftToeBase"}, lambda n: n.replace("Left", "Right")),
    "bandai": _both_sides({  # Bandai Namco Research Motion Dataset
        "Hips": "Hips", "Spine": "Spine", "Chest": "Spine1", "Neck": "Neck", "Head": "Head",
        "Shoulder_L": "LeftShoulder", "UpperArm_L": "LeftArm", "LowerArm_L": "LeftForeArm", "Hand_L": "LeftHand",
        "UpperLeg_L": "LeftUpLeg", "LowerLeg_L": "LeftLeg", "Foot_L": "LeftFoot", "Toes_L": "LeftToeBase"},
        lambda n: n[:-1] + "R"),
    "mixamo": _both_sides({  # Mixamo (names after the "mixamorig:" prefix)
        "Hips": "Hips", "Spine": "LowerBack", "Spine1": "Spine", "Spine2": "Spine1", "Neck": "Neck",
        "Head": "Head", "LeftShoulder": "LeftShoulder", "LeftArm": "LeftArm", "LeftForeArm": "LeftForeArm",
        "LeftHand": "LeftHand", "LeftUpLeg": "LeftUpLeg", "LeftLeg": "LeftLeg", "LeftFoot": "LeftFoot",
        "LeftToeBase": "LeftToeBase"}, lambda n: n.replace("Left", "Right")),
}
_LEFT_OUT = {
    "cmu_motionbuilder": set(VICON_HAND_JOINTS),
    "vicon_asf": {VICON_BVH_TO_ASF[n] for n in VICON_HAND_JOINTS},
    "cmu_3dsmax": {"Chest3"},
    "bandai": {"joint_Root"},
    "mixamo": set(),
}
# Fingers, thumbs, eyes and end joints ("HeadTop_End", "LeftToe_End", "LeftHandNub") of any convention.
_LEFT_OUT_ANYWHERE = re.compile(r"(Thumb|Index|Middle|Ring|Pinky|Finger|Eye)\d*|(_?End|Nub)$", re.IGNORECASE)


class SkeletonMapError(ValueError):
    """A file's joints could not all be placed on the CCNet 25-joint topology."""


def _strip_namespace(name: str) -> str:
    return name.rsplit(":", 1)[-1]  # "mixamorig:Hips" -> "Hips"


def read_explicit_map(explicit: dict | str | Path | None) -> dict:
    """An explicit joint map (a dict, or a path to a JSON object) as a dict ({} for None),
    its targets checked to be CCNet joints (or None, to skip a joint)."""
    if isinstance(explicit, (str, Path)):
        explicit = json.loads(Path(explicit).read_text())
    explicit = dict(explicit or {})
    bad = {k: v for k, v in explicit.items() if v is not None and v not in CCNET_25_JOINTS}
    if bad:
        raise SkeletonMapError(f"explicit map targets that are not CCNet joints: {bad}; "
                               f"choose from {', '.join(CCNET_25_JOINTS)}")
    return explicit


def closest_convention(names) -> str:
    """The key of :data:`NAME_CONVENTIONS` whose table holds the most of ``names``."""
    bare = [_strip_namespace(n) for n in names]
    return max(NAME_CONVENTIONS, key=lambda conv: sum(b in NAME_CONVENTIONS[conv] for b in bare))


def map_to_ccnet25(names, explicit: dict | str | Path | None = None) -> dict[str, str]:
    """{file joint name: CCNet 25-joint name} for the joints of ``names`` that have one.

    The naming convention (see :data:`NAME_CONVENTIONS`: CMU MotionBuilder- and
    3dsMax-friendly BVH, VICON ASF, Bandai, Mixamo with any ``namespace:`` prefix) is the one
    that places the most joints. Joints the 25 leave out (fingers, end joints, a reference
    root) are skipped. ``explicit`` (a dict, or a path to a JSON object) maps file names to
    CCNet names, or to null to skip a joint; it overrides the convention. Raises
    :class:`SkeletonMapError` naming every joint it could not place.
    """
    explicit = read_explicit_map(explicit)
    bare = {n: _strip_namespace(n) for n in names}
    conv = closest_convention(names)
    table, left_out = NAME_CONVENTIONS[conv], _LEFT_OUT[conv]
    out, unplaced = {}, []
    for name, b in bare.items():
        if name in explicit:
            if explicit[name] is not None:
                out[name] = explicit[name]
        elif b in table:
            out[name] = table[b]
        elif b not in left_out and not _LEFT_OUT_ANYWHERE.search(b):
            unplaced.append(name)
    if unplaced:
        example = json.dumps({unplaced[0]: "LeftUpLeg", **({unplaced[1]: None} if len(unplaced) > 1 else {})})
        raise SkeletonMapError(
            f"could not place {len(unplaced)} joint(s) on the CCNet 25-joint skeleton (closest naming "
            f"convention: {conv}): {', '.join(unplaced)}. Pass an explicit map, a dict or a JSON file "
            f"of file joint -> CCNet joint (null to skip it), e.g. {example}; CCNet joints: "
            f"{', '.join(CCNET_25_JOINTS)}")
    twice = {v for v in out.values() if list(out.values()).count(v) > 1}
    if twice:
        raise SkeletonMapError(f"several joints map to {sorted(twice)}: {out}")
    return out


def left_right_partner(name: str) -> str:
    """The mirror joint's name (itself for centre joints), for VICON, BVH and H3.6M names."""
    for a, b in (("Left", "Right"), ("left", "right"), ("L", "R"), ("l", "r")):
        if name.startswith(a) and not name.startswith(b):
            return b + name[len(a):]
        if name.startswith(b):
            return a + name[len(b):]
    return name


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint tree in topological order (``parents[j] < j``; the root has parent -1).

    ``offsets[j]`` is joint j's position in its parent's frame when all rotations are
    identity (the rest pose), in metres with Y up. ``end_sites`` are extra leaf points
    (joint index, offset) kept for drawing and for writing BVH back.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    end_sites: tuple[tuple[int, tuple[float, float, float]], ...] = field(default=())

    def __post_init__(self):
        parents = np.asarray(self.parents, dtype=np.int64)
        offsets = np.asarray(self.offsets, dtype=np.float64)
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        if offsets.shape != (len(self.names), 3) or parents.shape != (len(self.names),):
            raise ValueError("names, parents and offsets must have one entry per joint")
        if parents[0] != -1 or np.any(parents[1:] >= np.arange(1, len(parents))):
            raise ValueError("joints must be in topological order with the root first")

    @property
    def n_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint named {name!r}") from None

    def children(self, joint: int) -> list[int]:
        return [int(j) for j in np.flatnonzero(self.parents == joint)]

    def bone_lengths(self) -> np.ndarray:
        """Length of the bone from each joint's parent to the joint (0 for the root)."""
        return np.linalg.norm(self.offsets, axis=-1)

    def rest_positions(self) -> np.ndarray:
        """Joint positions (J, 3) with every rotation identity and the root at the origin."""
        pos = np.zeros_like(self.offsets)
        for j in range(1, self.n_joints):
            pos[j] = pos[self.parents[j]] + self.offsets[j]
        return pos

    def end_site_positions(self) -> np.ndarray:
        rest = self.rest_positions()
        return np.array([rest[j] + np.asarray(off) for j, off in self.end_sites]).reshape(-1, 3)

    def chain(self, joint: int) -> list[int]:
        """Joints from the root down to ``joint`` inclusive."""
        out = [joint]
        while self.parents[out[-1]] >= 0:
            out.append(int(self.parents[out[-1]]))
        return out[::-1]

    def renamed(self, mapping: dict[str, str]) -> "Skeleton":
        return Skeleton(tuple(mapping.get(n, n) for n in self.names), self.parents,
                        self.offsets, self.end_sites)

    def keep_joints(self, names) -> tuple["Skeleton", np.ndarray]:
        """Sub-skeleton of the named joints, and their indices in this skeleton.

        Dropped joints must form whole subtrees (e.g. hands and fingers), so that no kept
        joint changes position: FK of the sub-skeleton equals FK of the full one.
        """
        keep = sorted(self.index(n) for n in names)
        keep_set = set(keep)
        for j in keep:
            p = self.parents[j]
            if p >= 0 and p not in keep_set:
                raise ValueError(f"cannot drop {self.names[p]!r}: its child {self.names[j]!r} is kept")
        remap = {old: new for new, old in enumerate(keep)}
        parents = np.array([-1 if self.parents[j] < 0 else remap[int(self.parents[j])] for j in keep])
        ends = [(remap[j], off) for j, off in self.end_sites if j in keep_set]
        for j in range(self.n_joints):  # a kept joint that lost all its children gets an end site
            if j in keep_set and self.children(j) and not any(c in keep_set for c in self.children(j)):
                ends.append((remap[j], tuple(self.offsets[self.children(j)[0]])))
        sub = Skeleton(tuple(self.names[j] for j in keep), parents, self.offsets[keep], tuple(ends))
        return sub, np.array(keep)

    def mirror_map(self) -> np.ndarray:
        """Index of each joint's left/right partner (itself for centre joints)."""
        partner = []
        for n in self.names:
            other = left_right_partner(n)
            partner.append(self.names.index(other) if other in self.names else self.names.index(n))
        return np.array(partner)

    def body_root(self) -> int:
        """The first joint, from the root down, that branches (Hips under a reference root)."""
        j = 0
        while len(kids := self.children(j)) == 1:
            j = kids[0]
        return j

    def height_from_bones(self) -> float:
        """Standing height estimated from bone lengths and the tree alone (any rest pose, any
        axes): the leg (body root to ankle) plus the trunk (body root to the chest's branch
        point, then its shortest branch, the neck and head, with the head's end).

        Bones at and above the body root do not count (a reference root, or a placement
        OFFSET such as Bandai's ``Hips`` that holds the take's start position). Used to guess
        a file's unit: Bandai's rest skeleton lies along X, so heights read off the rest pose
        are wrong there.
        """
        base = self.body_root()
        lengths = self.bone_lengths()
        tip = dict.fromkeys(range(self.n_joints), 0.0)  # longest end-site offset per joint
        for j, off in self.end_sites:
            tip[j] = max(tip[j], float(np.linalg.norm(off)))

        def reach(j: int) -> tuple[float, float]:
            """Longest path from j's bone start to a leaf's end, and that leaf's bone + end."""
            kids = self.children(j)
            if not kids:
                return lengths[j] + tip[j], lengths[j] + tip[j]
            total, tail = max(reach(c) for c in kids)
            return lengths[j] + total, tail

        def size(j: int) -> int:
            return 1 + sum(size(c) for c in self.children(j))

        kids = sorted(self.children(base), key=size)
        if not kids:
            return 0.0
        trunk, j = 0.0, kids[-1]  # the trunk holds the most joints (arms, neck, head)
        while len(self.children(j)) == 1:
            trunk += lengths[j]
            j = self.children(j)[0]
        branches = self.children(j)
        trunk += lengths[j] + (min(reach(c)[0] for c in branches) if branches else tip[j])
        # a leg to the ankle: its longest path without the foot's last bone (the toe)
        leg = max((reach(c)[0] - reach(c)[1] for c in kids[:-1]), default=0.0)
        return float(trunk + leg)

    def standing_height(self) -> float:
        """Estimated standing height in metres: straightened leg plus trunk, head and feet.

        The rest pose of VICON skeletons splays the legs by ~20 degrees, so the rest-pose
        bounding box underestimates height; summing bone lengths along the vertical chains
        (root -> head end, hip -> ankle) plus the ankle's height above the toe does not.
        A rest pose that does not stand along Y (Bandai's lies along X; its rotations stand
        it up) falls back to :meth:`height_from_bones`.
        """
        rest = self.rest_positions()
        by_bones = self.height_from_bones()
        base = self.body_root()
        if np.ptp(rest[[j for j in range(self.n_joints) if base in self.chain(j)], 1]) < 0.5 * by_bones:
            return by_bones
        ends = self.end_site_positions()
        top_candidates = [(j, rest[j][1]) for j in range(self.n_joints)]
        for (j, _), p in zip(self.end_sites, ends):
            top_candidates.append((j, p[1]))
        top_joint = max(top_candidates, key=lambda c: c[1])[0]
        trunk = sum(self.bone_lengths()[self.chain(top_joint)])
        head_end = [np.linalg.norm(off) for j, off in self.end_sites if j == top_joint]
        trunk += max(head_end, default=0.0)
        low = int(np.argmin(rest[:, 1]))
        chain = self.chain(low)
        # leg bones hang down from the hip: take lengths of bones with a downward component,
        # except the lowest (foot->toe) bone, which lies mostly forward: use its drop only.
        leg = 0.0
        for a, b in zip(chain[:-2], chain[1:-1]):
            d = self.offsets[b]
            if d[1] < 0:
                leg += np.linalg.norm(d)
        leg += -min(self.offsets[chain[-1]][1], 0.0)
        return float(trunk + leg)

    def configuration(self) -> np.ndarray:
        """CCNet's skeleton configuration c^s: root height, then root-relative rest joints.

        Root height is the root's height above the lowest rest-pose point (the rest pose of
        the file, all rotations identity); the other 3(J-1) values are rest joint positions
        relative to the root.
        """
        rest = self.rest_positions()
        ends = self.end_site_positions()
        lowest = min(rest[:, 1].min(), ends[:, 1].min() if len(ends) else np.inf)
        return np.concatenate([[rest[0, 1] - lowest], (rest[1:] - rest[0]).ravel()])
