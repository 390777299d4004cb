"""A file's joints placed on CCNet's 25 from the joint tree and the rest pose, not from names.

The name tables of :func:`mocapviz.skeleton.map_to_ccnet25` know five conventions; any other
exporter (a CMU release with ``lowerback`` beside ``Chest``, Xsens ``L5``/``T8``, Unreal
``spine_01``, Rigify ``DEF-thigh.L``) failed on its first unknown name. :func:`map_from_tree`
reads the body off the tree instead:

- fingers, thumbs, eyes, jaws, twist and roll bones, IK helpers and end joints (``*_End``,
  ``*Nub``) never take a CCNet joint ("passive"); the others are "core";
- the hips are the deepest joint below which at least five core chains end (two feet, two
  hands, a head); joints above them (a reference root) are skipped;
- the torso is the hips' branch with the most chain ends; the head is its end that stands
  highest (up is from the other chains' ends to the torso's, so Y up and Z up alike), the hands its
  two ends farthest from the up line through the hips, one in each arm; the chest (CCNet ``Spine1``) is where
  the arms and the head part; the legs are the two lowest chain ends outside the torso, and
  they must hang below the hips, or the file is refused as not a humanoid;
- along a leg, the ankle is the end of the last bone that points down (within 35 degrees), the
  thigh and knee the pair whose thigh and shin are nearest equal with the knee halfway down, a
  joint above the thigh the hip stub (``LHipJoint``), the first joint past the ankle the toe
  (one named toe or ball first); along an arm, the hand is the joint named wrist (else hand,
  else the last), the upper arm and elbow the pair whose upper arm is nearest 1.2 forearms
  with the elbow ~55 % of the way, a joint above the upper arm the clavicle;
- a spine of more joints than CCNet's three gives ``LowerBack`` and ``Spine`` its first two
  and ``Spine1`` the chest, a neck of more than two gives ``Neck`` and ``Neck1`` its first two
  (after any joint before the first one named neck); fewer, and the missing CCNet joints are
  made up by :class:`mocapviz.tasks.rig.ModelRig` (as
  :func:`~mocapviz.features.ccnet_joints.complete_ccnet25` does for the training data).

Unmapped joints on a path between two mapped ones are "composed": the rig matches global
rotations, so their rotation is carried by the mapped joint below them. Name cues (hip/thigh/
upleg, knee/leg/shin/calf, ankle/foot, toe/ball, collar/clavicle/shoulder, arm/humerus,
elbow/forearm, wrist/hand) shift a choice by 0.3 of the geometric cost: they break ties.
Left and right come from names when a joint's name with its side marker swapped is another
joint's (``LeftArm``/``RightArm``, ``thigh_l``/``thigh_r``, ``lfemur``/``rfemur``), else from
the rest pose (left = up x forward, forward from ankle to toe).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from mocapviz.features.ccnet_joints import CCNET_25_PARENTS
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton, SkeletonMapError, closest_convention, map_to_ccnet25, \
    read_explicit_map

PASSIVE = re.compile(r"thumb|index|middle|ring|pinky|pinkie|finger|palm|carpal|eye|jaw|tongue|teeth|twist|roll|breast|^ik_|_ik$",
                     re.IGNORECASE)
END_JOINT = re.compile(r"(End|_end|Nub|Site)$")  # case-sensitive: Daz's "lThighBend" is a thigh
CUES = {k: re.compile(v) for k, v in {
    "thigh": r"hip|thigh|upleg|upperleg|femur", "knee": r"knee|shin|calf|lowerleg|tibia|(?<!up)(?<!upper)leg",
    "toe": r"toe|ball", "clavicle": r"collar|clavicle", "arm": r"upperarm|uparm|humerus|shldr|(?<!fore)(?<!lower)arm",
    "forearm": r"forearm|lowerarm|elbow|radius|ulna", "wrist": r"wrist", "hand": r"hand", "neck": r"neck",
    "head": r"head"}.items()}
SIDE_MARKERS = (("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT"), ("L", "R"), ("l", "r"))
DOWN_COS = np.cos(np.radians(35.0))  # a bone points down within 35 degrees of straight down
CUE_WEIGHT = 0.3


class NotHumanoidError(SkeletonMapError):
    """The tree is not a humanoid's (a quadruped, a hand only): the message says what was found."""


@dataclass
class JointMapping:
    """How a file's joints take CCNet's 25: ``mapping`` file joint -> CCNet joint; ``composed``
    file joint -> the CCNet joint whose rotation carries it; ``skipped`` file joints (fingers,
    toe tips, end joints, a reference root); ``made_up`` CCNet joints no file joint takes;
    ``method`` how it was found."""

    mapping: dict[str, str]
    composed: dict[str, str] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    made_up: list[str] = field(default_factory=list)
    method: str = "tree"

    def table(self) -> str:
        """The mapping as text: one row per CCNet joint, then composed and skipped joints."""
        by_ccnet = {v: k for k, v in self.mapping.items()}
        width = max([len(k) for k in self.mapping] + [12])
        rows = [f"mapping found by: {self.method}", f"{'file joint':<{width}}  CCNet joint"]
        rows += [f"{by_ccnet.get(c, '(made up)'):<{width}}  {c}" for c in CCNET_25_JOINTS]
        if self.composed:
            rows.append("composed (rotation carried by the CCNet joint): "
                        + ", ".join(f"{k} -> {v}" for k, v in self.composed.items()))
        if self.skipped:
            rows.append("skipped (fingers, toe tips, end joints, a reference root): " + ", ".join(self.skipped))
        return "\n".join(rows)


def finish(skeleton: Skeleton, mapping: dict[str, str], method: str) -> JointMapping:
    """The JointMapping of ``mapping``: unmapped joints between mapped ones on the way down to a
    mapped joint are composed into it, the others skipped."""
    mapped = {skeleton.index(f) for f in mapping}
    composed = {}
    for j in sorted(mapped):
        for k in skeleton.chain(j)[:-1][::-1]:
            if k in mapped:
                break
            if any(a in mapped for a in skeleton.chain(k)[:-1]):
                composed.setdefault(skeleton.names[k], mapping[skeleton.names[j]])
    skipped = [n for j, n in enumerate(skeleton.names) if j not in mapped and n not in composed]
    return JointMapping(dict(mapping), composed, skipped, [c for c in CCNET_25_JOINTS if c not in mapping.values()],
                        method)


def consistent(skeleton: Skeleton, mapping: dict[str, str]) -> bool:
    """Whether ``mapping`` keeps CCNet's tree: each mapped joint's nearest mapped ancestor maps
    to an ancestor of its CCNet joint, and the rig can make up the missing CCNet joints."""
    core = {"Hips", "Spine1", "Head"} | {f"{s}{p}" for s in ("Left", "Right")
                                        for p in ("UpLeg", "Leg", "Foot", "Arm", "ForeArm", "Hand")}
    if not core <= set(mapping.values()) or len(set(mapping.values())) != len(mapping):
        return False
    for name, target in mapping.items():
        ancestors, c = [], target
        while (c := CCNET_25_PARENTS[c]) is not None:
            ancestors.append(c)
        up = [skeleton.names[k] for k in skeleton.chain(skeleton.index(name))[:-1] if skeleton.names[k] in mapping]
        if (up and mapping[up[-1]] not in ancestors) or (not up and target != "Hips"):
            return False
    return True


def _cue(name: str, key: str) -> bool:
    return bool(CUES[key].search(re.sub(r"[^a-z0-9]", "", name.rsplit(":", 1)[-1].lower())))


def side_of(name: str, names: set[str]) -> int:
    """+1 (left) or -1 (right) when swapping a side marker in ``name`` gives another joint's
    name, else 0."""
    for a, b in SIDE_MARKERS:
        for sign, (x, y) in ((1, (a, b)), (-1, (b, a))):
            i = name.find(x)
            while i >= 0:
                if name[:i] + y + name[i + len(x):] in names:
                    return sign
                i = name.find(x, i + 1)
    return 0


class _Tree:
    """A skeleton with its rest positions, passive joints and chain ends (core leaves)."""

    def __init__(self, skeleton: Skeleton, source: str):
        self.sk, self.source = skeleton, source or "the file"
        self.pos = skeleton.rest_positions()
        n = skeleton.n_joints
        self.kids = [skeleton.children(j) for j in range(n)]
        marked = [bool(PASSIVE.search(nm) or END_JOINT.search(nm)) for nm in skeleton.names]
        self.core = [False] * n  # not marked, or above a joint that is not
        for j in range(n - 1, -1, -1):
            self.core[j] = not marked[j] or any(self.core[k] for k in self.kids[j])
        self.eligible = [self.core[j] and not marked[j] for j in range(n)]
        self.leaves = [j for j in range(n) if self.core[j] and not any(self.core[k] for k in self.kids[j])]

    def name(self, j) -> str:
        return self.sk.names[j]

    def refuse(self, why: str):
        ends = ", ".join(self.name(j) for j in self.leaves) or "none"
        raise NotHumanoidError(
            f"{self.source}: not a humanoid skeleton: {why}. Found {self.sk.n_joints} joints; the core chains "
            f"(without fingers, twist bones, end joints) end at: {ends}. Map it by hand: an explicit joint map, "
            f"file joint -> CCNet joint (on the command line: --joint-map FILE.json)")

    def below(self, top: int, leaf: int) -> list[int]:
        """The path from ``top`` (exclusive) down to ``leaf`` (inclusive)."""
        chain = self.sk.chain(leaf)
        return chain[chain.index(top) + 1:]

    def leaves_under(self, j: int) -> list[int]:
        return [k for k in self.leaves if j in self.sk.chain(k)]


def _down(vec: np.ndarray, up: np.ndarray) -> bool:
    norm = np.linalg.norm(vec)
    return norm > 1e-6 and -(vec @ up) / norm > DOWN_COS


def _pair(t: _Tree, chain: list[int], end: int, cost_of) -> tuple[int, int]:
    """The (start, middle) indices into ``chain`` before ``end`` of least ``cost_of(s, e)``."""
    best = None
    for s in range(end):
        for e in range(s + 1, end):
            if t.eligible[chain[s]] and t.eligible[chain[e]]:
                cost = cost_of(chain[s], chain[e])
                if best is None or cost < best[0] - 1e-9:
                    best = (cost, s, e)
    if best is None:
        t.refuse(f"the limb {t.name(chain[0])} .. {t.name(chain[end])} has too few joints for two bones")
    return best[1], best[2]


def _leg(t: _Tree, chain: list[int], hips: int, up: np.ndarray) -> dict[str, int]:
    """Roles (hip, thigh, knee, ankle, toe) -> joint of one leg chain (hips exclusive)."""
    p, prev = t.pos, [hips] + chain[:-1]
    downs = [i for i, j in enumerate(chain) if t.eligible[j] and _down(p[j] - p[prev[i]], up)]
    if not downs:
        t.refuse(f"no bone of the chain {t.name(chain[0])} .. {t.name(chain[-1])} points down")
    f = downs[-1]
    ankle = chain[f]

    def cost(s, e):
        thigh, shin = np.linalg.norm(p[e] - p[s]), np.linalg.norm(p[ankle] - p[e])
        drop = (p[s] - p[ankle]) @ up
        half = abs((p[s] - p[e]) @ up / drop - 0.5) if drop > 1e-6 else 1.0
        out = [k for k in t.kids[s] if k in chain]
        names = (_cue(t.name(e), "thigh") - _cue(t.name(e), "knee") - _cue(t.name(s), "thigh")
                 + _cue(t.name(s), "knee"))
        return (abs(np.log(max(thigh, 1e-6) / max(shin, 1e-6))) + 2 * half + (not _down(p[e] - p[s], up))
                + 0.5 * (not out or not _down(p[out[0]] - p[s], up)) + CUE_WEIGHT * names)
    s, e = _pair(t, chain, f, cost)
    roles = {"thigh": chain[s], "knee": chain[e], "ankle": ankle}
    stub = [j for j in chain[:s] if t.eligible[j]]
    if stub:
        roles["hip"] = stub[0]
    after = [j for j in chain[f + 1:] if t.eligible[j]]
    if after:
        roles["toe"] = next((j for j in after if _cue(t.name(j), "toe")), after[0])
    return roles


def _arm(t: _Tree, chain: list[int]) -> dict[str, int]:
    """Roles (clavicle, arm, forearm, hand) -> joint of one arm chain (chest exclusive)."""
    p, ok = t.pos, [j for j in chain if t.eligible[j]]
    hand = next((j for j in ok if _cue(t.name(j), "wrist")), None) or \
        next((j for j in ok if _cue(t.name(j), "hand")), ok[-1] if ok else None)
    if hand is None:
        t.refuse("an arm chain has no joints")
    w = chain.index(hand)

    def cost(s, e):
        upper, fore = np.linalg.norm(p[e] - p[s]), np.linalg.norm(p[hand] - p[e])
        names = (_cue(t.name(e), "arm") - _cue(t.name(e), "forearm") - _cue(t.name(s), "arm")
                 + _cue(t.name(s), "forearm") + _cue(t.name(s), "clavicle"))
        return (abs(np.log(max(upper, 1e-6) / max(fore, 1e-6) / 1.2))
                + 2 * abs(upper / max(upper + fore, 1e-6) - 0.55) + CUE_WEIGHT * names)
    s, e = _pair(t, chain, w, cost)
    roles = {"arm": chain[s], "forearm": chain[e], "hand": hand}
    above = [j for j in chain[:s] if t.eligible[j]]
    if above:
        roles["clavicle"] = above[0]
    return roles


def _sides(t: _Tree, a: list[int], b: list[int], left: np.ndarray, base: int) -> tuple[list[int], list[int]]:
    """The two chains as (left, right): by names where they say it, else by the rest pose."""
    names = set(t.sk.names)
    va, vb = (sum(side_of(t.name(j), names) for j in c) for c in (a, b))
    if np.sign(va) != np.sign(vb) and va != vb:
        return (a, b) if va > vb else (b, a)
    la, lb = ((t.pos[c[-1]] - t.pos[base]) @ left for c in (a, b))
    return (a, b) if la >= lb else (b, a)


def map_from_tree(skeleton: Skeleton, source: str = "") -> JointMapping:
    """The CCNet mapping of ``skeleton`` read off its tree and rest pose (module docstring).
    ``source`` names the file in errors. Raises :class:`NotHumanoidError` for a tree that is
    not a humanoid's."""
    t = _Tree(skeleton, source)
    if len(t.leaves) < 5:
        t.refuse(f"{len(t.leaves)} core chain end(s), a humanoid has at least five (two feet, two hands, a head)")
    counts = [len(t.leaves_under(j)) for j in range(skeleton.n_joints)]
    hips = max((j for j in range(skeleton.n_joints) if counts[j] >= 5), key=lambda j: len(skeleton.chain(j)))
    branches = [k for k in t.kids[hips] if t.core[k]]
    torso = max(branches, key=lambda k: counts[k])
    top, rest = t.leaves_under(torso), [j for j in t.leaves_under(hips) if j not in t.leaves_under(torso)]
    if len(top) < 3 or len(rest) < 2:
        t.refuse(f"below the hips candidate {t.name(hips)!r} the largest branch ends {len(top)} time(s) and the "
                 f"others {len(rest)} time(s); a humanoid's torso ends at least 3 times (hands, head), its legs twice")
    p = t.pos - t.pos[hips]
    up0 = p[top].mean(axis=0) - p[rest].mean(axis=0)
    up0 /= max(np.linalg.norm(up0), 1e-9)
    head_end = max(top, key=lambda j: p[j] @ up0 + 0.05 * np.ptp(p @ up0) * _cue(t.name(j), "head"))
    up = p[head_end] / max(np.linalg.norm(p[head_end]), 1e-9)
    def lca(a, b):
        return max(set(skeleton.chain(a)) & set(skeleton.chain(b)), key=lambda j: len(skeleton.chain(j)))

    off_axis = sorted((j for j in top if j != head_end), key=lambda j: -np.linalg.norm(p[j] - (p[j] @ up) * up))
    other = [j for j in off_axis[1:] if lca(off_axis[0], j) in skeleton.chain(lca(off_axis[0], head_end))]
    if not other:
        t.refuse(f"the torso's chains {', '.join(t.name(j) for j in off_axis)} do not make two arms")
    hands = [off_axis[0], other[0]]
    feet = sorted(rest, key=lambda j: p[j] @ up)[:2]
    for f in feet:
        length = sum(np.linalg.norm(skeleton.offsets[k]) for k in t.below(hips, f))
        if -(p[f] @ up) < 0.5 * length:
            t.refuse(f"the two lowest chains outside the torso ({', '.join(t.name(j) for j in feet)}) do not hang "
                     f"below the hips {t.name(hips)!r} (a quadruped or a lying rest pose?)")
    chest = lca(lca(*hands), head_end)
    if chest == hips:
        t.refuse(f"the arms and the head part at the hips {t.name(hips)!r}: there is no spine")
    legs = [t.below(hips, f) for f in feet]
    legs = [[j for j in c if j not in legs[1 - i]] for i, c in enumerate(legs)]  # without a shared pelvis
    arms = [t.below(chest, h) for h in hands]
    arms = [[j for j in c if j not in arms[1 - i] and j not in skeleton.chain(head_end)] for i, c in enumerate(arms)]
    leg_roles = [_leg(t, c, hips, up) for c in legs]
    fwd = [p[r["toe"]] - p[r["ankle"]] for r in leg_roles if "toe" in r]
    fwd = np.mean(fwd, axis=0) - (np.mean(fwd, axis=0) @ up) * up if fwd else np.zeros(3)
    if np.linalg.norm(fwd) > 1e-3:
        left = np.cross(up, fwd)
    else:  # no toes: facing +Z with Y up, or -Y with Z up, left is +X either way
        left = np.array([1.0, 0.0, 0.0]) - up[0] * up
    out = {hips: "Hips"}
    lleg, _ = _sides(t, *legs, left, hips)
    for chain, roles in zip(legs, leg_roles):
        side = "Left" if chain is lleg else "Right"
        names = {"hip": f"{side[0]}HipJoint", "thigh": f"{side}UpLeg", "knee": f"{side}Leg", "ankle": f"{side}Foot",
                 "toe": f"{side}ToeBase"}
        out.update({j: names[r] for r, j in roles.items()})
    larm, _ = _sides(t, *arms, left, chest)
    for chain in arms:
        side = "Left" if chain is larm else "Right"
        names = {"clavicle": f"{side}Shoulder", "arm": f"{side}Arm", "forearm": f"{side}ForeArm", "hand": f"{side}Hand"}
        out.update({j: names[r] for r, j in _arm(t, chain).items()})
    spine = [j for j in t.below(hips, chest)[:-1] if t.eligible[j]]
    out.update(dict(zip(spine[:2], ("LowerBack", "Spine") if len(spine) >= 2 else ("Spine",))))
    out[chest] = "Spine1"
    neck = [j for j in t.below(chest, head_end) if t.eligible[j]]
    head = next((j for j in neck if _cue(t.name(j), "head")), neck[-1] if neck else None)
    if head is None:
        t.refuse(f"nothing between the chest {t.name(chest)!r} and the head end")
    neck = neck[:neck.index(head)]
    named = [i for i, j in enumerate(neck) if _cue(t.name(j), "neck")]
    neck = neck[named[0]:] if named else neck
    out.update(dict(zip(neck[:2], ("Neck", "Neck1"))))
    out[head] = "Head"
    return finish(skeleton, {skeleton.names[j]: c for j, c in sorted(out.items())}, "the tree and the rest pose")


def map_skeleton(skeleton: Skeleton, explicit=None, source: str = "") -> JointMapping:
    """How ``skeleton``'s joints take CCNet's 25: by a naming convention's table
    (:func:`mocapviz.skeleton.map_to_ccnet25`) where it places every joint and keeps CCNet's
    tree, else from the tree (:func:`map_from_tree`). ``explicit`` (a dict or a JSON file, file
    joint -> CCNet joint or None to skip it) overrides either; a CCNet joint it gives to one
    file joint is taken from any other. ``source`` names the file in errors."""
    explicit = read_explicit_map(explicit)
    table = None
    try:
        table = map_to_ccnet25(skeleton.names, explicit)
    except SkeletonMapError as e:  # a joint no table knows, or two joints on one CCNet joint
        table_error = e
    if table is not None and (explicit or consistent(skeleton, table)):
        return finish(skeleton, table, f"joint names ({closest_convention(skeleton.names)} convention)"
                      + (", with the explicit map over it" if explicit else ""))
    try:
        tree = map_from_tree(skeleton, source)
    except NotHumanoidError:
        if explicit:
            raise SkeletonMapError(f"{source or 'the file'}: {table_error}") from None
        raise
    if not explicit:
        return tree
    out = {f: c for f, c in tree.mapping.items() if c not in explicit.values() and f not in explicit}
    out.update({f: c for f, c in explicit.items() if c is not None})
    return finish(skeleton, {n: out[n] for n in skeleton.names if n in out},
                  "the tree and the rest pose, with the explicit map over it")
