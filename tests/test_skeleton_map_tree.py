"""Skeletons of many exporters placed on CCNet's 25 joints from the tree and the rest pose.

Each convention is written here as a small hierarchy (no third-party file is copied): the
joint names and nesting the exporter writes, on one body (cm, a T-pose unless said, left =
+X, Y up, facing +Z) turned to the exporter's axes. Beside each joint stands the CCNet joint
a person would give it (None: composed into the CCNet joint below it, or skipped). Then the
real files of the data folder map as they did by name.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import DATA_DIR
from mocapviz.io.asfamc import read_asf
from mocapviz.io.bvh import read_bvh
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton, SkeletonMapError, map_to_ccnet25
from mocapviz.skeleton_map import NotHumanoidError, consistent, map_from_tree, map_skeleton, side_of

# Body positions (cm) of the left side by role; the right side mirrors X.
LEG = {"stub": (0, 0, 0), "thigh": (9, -6, 0), "thigh2": (10.5, -27, 0), "knee": (12, -48, 1),
       "shin2": (12.5, -68, 0), "ankle": (13, -88, -1), "forefoot": (13, -94, 7), "toe": (13, -96, 12),
       "toetip": (13, -96, 19)}
ARM = {"clav": (2, 43, 0), "arm": (17, 45, 0), "arm2": (30, 45, 0), "fore": (44, 45, 0), "fore2": (54, 45, 0),
       "wrist": (65, 45, 0), "palm": (73, 45, 0)}


def _apose(pos):
    """An arm position turned 40 degrees down about the shoulder (an A-pose)."""
    d = np.subtract(pos, ARM["arm"])
    if d[0] <= 0:
        return np.asarray(pos, float)
    c, s = np.cos(np.radians(-40)), np.sin(np.radians(-40))
    return np.asarray(ARM["arm"], float) + [c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]]


def humanoid(hips, spine, neck, legs, arms, *, sides=("Left", "Right"), root=None, pelvis=None, fingers=(),
             extra=(), up="y", facing=1, apose=False):
    """(Skeleton, expected {file joint: CCNet joint}) of a humanoid written by a convention.

    ``spine``: (name, CCNet) from the hips up to the chest, where arms and neck start;
    ``neck``: (name, CCNet) from the chest to the head and beyond; ``legs`` / ``arms``:
    (name template with {s} for the side, role of :data:`LEG` / :data:`ARM`, CCNet template
    with {S} for Left/Right); ``fingers``: chains of templates under the last arm joint;
    ``extra``: (template, parent template, body position) joints per side; ``pelvis``: a
    joint between the hips and both thighs; ``root``: a reference root above the hips;
    ``up``: "y", or "z" (facing -Y); ``facing``: -1 turns the body to face -Z.
    """
    joints, expected = [], {}  # (name, parent, position)

    def add(name, parent, pos, ccnet=None):
        joints.append((name, parent, np.asarray(pos, float)))
        if ccnet is not None:
            expected[name] = ccnet
    if root:
        add(root, None, (0, 0, 0))
    add(hips, root, (0, 95, 0), "Hips")
    for i, (name, cc) in enumerate(spine):
        add(name, joints[-1][0] if i else hips, (0, 95 + 45 * (i + 1) / len(spine), -1), cc)
    chest = joints[-1][0]
    for i, (name, cc) in enumerate(neck):
        add(name, joints[-1][0] if i else chest, (0, 145 + 12 * i / max(len(neck) - 1, 1) + 5 * (i >= len(neck) - 1), 0), cc)
    if pelvis:
        add(pelvis, hips, (0, 92, 0))
    for k, (s, side) in enumerate(zip(sides, ("Left", "Right"))):
        mirror = np.array([1 - 2 * k, 1, 1])
        parent = pelvis or hips
        for tpl, role, cc in legs:
            add(tpl.format(s=s), parent, np.add(LEG[role], (0, 95, 0)) * mirror, cc and cc.format(S=side))
            parent = tpl.format(s=s)
        parent = chest
        for tpl, role, cc in arms:
            pos = _apose(ARM[role]) if apose else np.asarray(ARM[role], float)
            add(tpl.format(s=s), parent, np.add(pos, (0, 95, 0)) * mirror, cc and cc.format(S=side))
            parent = tpl.format(s=s)
        hand = joints[-1][2]
        for f, chain in enumerate(fingers):
            for i, tpl in enumerate(chain):
                add(tpl.format(s=s), joints[-1][0] if i else parent,
                    hand + np.multiply((4 + 3 * i, -1 if apose else 0, 2 * f - 3), mirror))
        for tpl, ptpl, pos in extra:
            add(tpl.format(s=s, l=s[0].lower()), ptpl.format(s=s), np.add(pos, (0, 95, 0)) * mirror)
    names = [n for n, _, _ in joints]
    pos = np.array([p for _, _, p in joints]) * 0.01
    if facing < 0:
        pos = pos * [-1, 1, -1]
    if up == "z":
        pos = np.stack([pos[:, 0], -pos[:, 2], pos[:, 1]], axis=1)
    parents = np.array([names.index(p) if p else -1 for _, p, _ in joints])
    offsets = pos - np.where(parents[:, None] >= 0, pos[parents], 0)
    ends = tuple((j, tuple(offsets[j] * 0.3)) for j in range(len(names)) if j not in parents)
    return Skeleton(tuple(names), parents, offsets, ends), expected


def bvh_text(sk: Skeleton) -> str:
    """BVH text (cm, one frame of zeros) of a skeleton."""
    lines, n_chan = ["HIERARCHY"], 0

    def emit(j, depth):
        nonlocal n_chan
        pad, root = "  " * depth, sk.parents[j] < 0
        off = " ".join(f"{v * 100:.4f}" for v in sk.offsets[j])
        lines.append(f"{pad}{'ROOT' if root else 'JOINT'} {sk.names[j]}\n{pad}{{\n{pad}  OFFSET {off}")
        lines.append(f"{pad}  CHANNELS {6 if root else 3} {'Xposition Yposition Zposition ' if root else ''}"
                     "Zrotation Xrotation Yrotation")
        n_chan += 6 if root else 3
        for k in sk.children(j):
            emit(k, depth + 1)
        for jj, off in sk.end_sites:
            if jj == j:
                lines.append(f"{pad}  End Site\n{pad}  {{\n{pad}    OFFSET "
                             + " ".join(f"{v * 100:.4f}" for v in off) + f"\n{pad}  }}")
        lines.append(f"{pad}}}")
    emit(0, 0)
    return "\n".join(lines) + f"\nMOTION\nFrames: 1\nFrame Time: 0.033333\n{' '.join(['0'] * n_chan)}\n"


MIXAMO_FINGERS = [[f"mixamorig:{{s}}Hand{f}{i}" for i in range(1, 5)] for f in ("Thumb", "Index", "Middle", "Ring", "Pinky")]
STD_LEGS = [("{s}UpLeg", "thigh", "{S}UpLeg"), ("{s}Leg", "knee", "{S}Leg"), ("{s}Foot", "ankle", "{S}Foot"),
            ("{s}ToeBase", "toe", "{S}ToeBase")]
STD_ARMS = [("{s}Shoulder", "clav", "{S}Shoulder"), ("{s}Arm", "arm", "{S}Arm"), ("{s}ForeArm", "fore", "{S}ForeArm"),
            ("{s}Hand", "wrist", "{S}Hand")]


def _prefixed(rows, prefix="mixamorig:"):
    return [(prefix + t, r, c) for t, r, c in rows]


CONVENTIONS = {
    "mixamo_fingers_y_up": lambda: humanoid(
        "mixamorig:Hips", [("mixamorig:Spine", "LowerBack"), ("mixamorig:Spine1", "Spine"), ("mixamorig:Spine2", "Spine1")],
        [("mixamorig:Neck", "Neck"), ("mixamorig:Head", "Head"), ("mixamorig:HeadTop_End", None)],
        _prefixed(STD_LEGS) + [("mixamorig:{s}Toe_End", "toetip", None)], _prefixed(STD_ARMS),
        fingers=MIXAMO_FINGERS),
    "mixamo_z_up_a_pose": lambda: humanoid(
        "mixamorig:Hips", [("mixamorig:Spine", "LowerBack"), ("mixamorig:Spine1", "Spine"), ("mixamorig:Spine2", "Spine1")],
        [("mixamorig:Neck", "Neck"), ("mixamorig:Head", "Head")], _prefixed(STD_LEGS), _prefixed(STD_ARMS),
        up="z", apose=True),
    "cmu_motionbuilder_z_up": lambda: humanoid(
        "Hips", [("LowerBack", "LowerBack"), ("Spine", "Spine"), ("Spine1", "Spine1")],
        [("Neck", "Neck"), ("Neck1", "Neck1"), ("Head", "Head")],
        [("{s[0]}HipJoint", "stub", "{S[0]}HipJoint")] + STD_LEGS,
        STD_ARMS + [("{s}FingerBase", "palm", None)], fingers=[["{s[0]}Thumb"]], up="z"),
    "cmu_3dsmax": lambda: humanoid(  # the 3dsMax-friendly CMU release: VICON stubs beside Chest/Chest2
        "Hips", [("lowerback", "LowerBack"), ("Chest", "Spine"), ("Chest2", "Spine1")],
        [("lowerneck", "Neck"), ("Neck", "Neck1"), ("Head", "Head")],
        [("{s[0]}HipJoint", "stub", "{S[0]}HipJoint"), ("{s}Hip", "thigh", "{S}UpLeg"), ("{s}Knee", "knee", "{S}Leg"),
         ("{s}Ankle", "ankle", "{S}Foot"), ("{s}Toe", "toe", "{S}ToeBase")],
        [("{s}Collar", "clav", "{S}Shoulder"), ("{s}Shoulder", "arm", "{S}Arm"), ("{s}Elbow", "fore", "{S}ForeArm"),
         ("{s}Wrist", "wrist", "{S}Hand")], extra=[("{l}hand", "{s}Wrist", (73, 45, 0))],
        sides=("Left", "Right")),
    "motionbuilder_spine3_forefoot": lambda: humanoid(
        "Hips", [("Spine", "LowerBack"), ("Spine1", "Spine"), ("Spine2", None), ("Spine3", "Spine1")],
        [("Neck", "Neck"), ("Head", "Head")],
        STD_LEGS[:3] + [("{s}ForeFoot", "forefoot", None), ("{s}ToeBase", "toe", "{S}ToeBase")], STD_ARMS),
    "xsens_mvn": lambda: humanoid(
        "Pelvis", [("L5", "LowerBack"), ("L3", "Spine"), ("T12", None), ("T8", "Spine1")],
        [("Neck", "Neck"), ("Head", "Head")],
        [("{s}UpperLeg", "thigh", "{S}UpLeg"), ("{s}LowerLeg", "knee", "{S}Leg"), ("{s}Foot", "ankle", "{S}Foot"),
         ("{s}Toe", "toe", "{S}ToeBase")],
        [("{s}Shoulder", "clav", "{S}Shoulder"), ("{s}UpperArm", "arm", "{S}Arm"), ("{s}ForeArm", "fore", "{S}ForeArm"),
         ("{s}Hand", "wrist", "{S}Hand")]),
    "axis_neuron_fingers": lambda: humanoid(  # no toes: CCNet's toe is made up at the foot's end site
        "Hips", [("Spine", "LowerBack"), ("Spine1", "Spine"), ("Spine2", None), ("Spine3", "Spine1")],
        [("Neck", "Neck"), ("Neck1", "Neck1"), ("Head", "Head")], STD_LEGS[:3], STD_ARMS,
        fingers=[["{s}HandThumb1", "{s}HandThumb2", "{s}HandThumb3"], ["{s}InHandIndex", "{s}HandIndex1", "{s}HandIndex2"],
                 ["{s}InHandMiddle", "{s}HandMiddle1", "{s}HandMiddle2"]]),
    "rokoko": lambda: humanoid(
        "Hips", [("Spine1", "LowerBack"), ("Spine2", "Spine"), ("Spine3", None), ("Spine4", "Spine1")],
        [("Neck", "Neck"), ("Head", "Head")],
        [("{s}Thigh", "thigh", "{S}UpLeg"), ("{s}Shin", "knee", "{S}Leg"), ("{s}Foot", "ankle", "{S}Foot"),
         ("{s}Toe", "toe", "{S}ToeBase"), ("{s}ToeEnd", "toetip", None)], STD_ARMS,
        fingers=[["{s}Finger1Metacarpal", "{s}Finger1Proximal"], ["{s}Finger2Metacarpal", "{s}Finger2Proximal"]]),
    "blender_rigify_z_up": lambda: humanoid(
        "DEF-spine", [("DEF-spine.001", "LowerBack"), ("DEF-spine.002", "Spine"), ("DEF-spine.003", "Spine1")],
        [("DEF-spine.004", "Neck"), ("DEF-spine.005", "Neck1"), ("DEF-spine.006", "Head")],
        [("DEF-thigh.{s}", "thigh", "{S}UpLeg"), ("DEF-thigh.{s}.001", "thigh2", None), ("DEF-shin.{s}", "knee", "{S}Leg"),
         ("DEF-shin.{s}.001", "shin2", None), ("DEF-foot.{s}", "ankle", "{S}Foot"), ("DEF-toe.{s}", "toe", "{S}ToeBase")],
        [("DEF-shoulder.{s}", "clav", "{S}Shoulder"), ("DEF-upper_arm.{s}", "arm", "{S}Arm"),
         ("DEF-upper_arm.{s}.001", "arm2", None), ("DEF-forearm.{s}", "fore", "{S}ForeArm"),
         ("DEF-forearm.{s}.001", "fore2", None), ("DEF-hand.{s}", "wrist", "{S}Hand")],
        sides=("L", "R"), up="z",
        fingers=[["DEF-palm.01.{s}", "DEF-f_index.01.{s}", "DEF-f_index.02.{s}"], ["DEF-thumb.01.{s}"]],
        extra=[("DEF-pelvis.{s}", "DEF-spine", (8, 6, 8)), ("DEF-breast.{s}", "DEF-spine.003", (9, 35, 8))]),
    "unreal_mannequin_z_up": lambda: humanoid(
        "pelvis", [("spine_01", "LowerBack"), ("spine_02", "Spine"), ("spine_03", "Spine1")],
        [("neck_01", "Neck"), ("head", "Head")],
        [("thigh_{s}", "thigh", "{S}UpLeg"), ("calf_{s}", "knee", "{S}Leg"), ("foot_{s}", "ankle", "{S}Foot"),
         ("ball_{s}", "toe", "{S}ToeBase")],
        [("clavicle_{s}", "clav", "{S}Shoulder"), ("upperarm_{s}", "arm", "{S}Arm"), ("lowerarm_{s}", "fore", "{S}ForeArm"),
         ("hand_{s}", "wrist", "{S}Hand")], sides=("l", "r"), root="root", up="z", facing=-1,
        fingers=[["index_01_{s}", "index_02_{s}"], ["thumb_01_{s}", "thumb_02_{s}"]],
        extra=[("upperarm_twist_01_{s}", "upperarm_{s}", (25, 45, 0)), ("calf_twist_01_{s}", "calf_{s}", (12, -60, 0)),
               ("thigh_twist_01_{s}", "thigh_{s}", (10, -20, 0)), ("ik_foot_{s}", "root", (13, -95, 0))]),
    "unity_humanoid_a_pose": lambda: humanoid(
        "Hips", [("Spine", "LowerBack"), ("Chest", "Spine"), ("UpperChest", "Spine1")],
        [("Neck", "Neck"), ("Head", "Head")],
        [("{s}UpperLeg", "thigh", "{S}UpLeg"), ("{s}LowerLeg", "knee", "{S}Leg"), ("{s}Foot", "ankle", "{S}Foot"),
         ("{s}Toes", "toe", "{S}ToeBase")],
        [("{s}Shoulder", "clav", "{S}Shoulder"), ("{s}UpperArm", "arm", "{S}Arm"), ("{s}LowerArm", "fore", "{S}ForeArm"),
         ("{s}Hand", "wrist", "{S}Hand")], apose=True,
        fingers=[["{s}ThumbProximal", "{s}ThumbIntermediate"], ["{s}IndexProximal", "{s}IndexIntermediate"]]),
    "humanik_reference_roll_bones": lambda: humanoid(
        "Hips", [("Spine", "LowerBack"), ("Spine1", "Spine"), ("Spine2", None), ("Spine3", "Spine1")],
        [("Neck", "Neck"), ("Neck1", "Neck1"), ("Head", "Head")], STD_LEGS, STD_ARMS, root="Reference",
        fingers=[["{s}HandThumb1", "{s}HandThumb2"], ["{s}HandIndex1", "{s}HandIndex2"]],
        extra=[("{s}UpLegRoll", "{s}UpLeg", (10, -25, 0)), ("{s}ForeArmRoll", "{s}ForeArm", (55, 45, 0))]),
    "hdm05_asf_names_z_up": lambda: humanoid(
        "root", [("lowerback", "LowerBack"), ("upperback", "Spine"), ("thorax", "Spine1")],
        [("lowerneck", "Neck"), ("upperneck", "Neck1"), ("head", "Head")],
        [("{s}hipjoint", "stub", "{S[0]}HipJoint"), ("{s}femur", "thigh", "{S}UpLeg"), ("{s}tibia", "knee", "{S}Leg"),
         ("{s}foot", "ankle", "{S}Foot"), ("{s}toes", "toe", "{S}ToeBase")],
        [("{s}clavicle", "clav", "{S}Shoulder"), ("{s}humerus", "arm", "{S}Arm"), ("{s}radius", "fore", "{S}ForeArm"),
         ("{s}wrist", "wrist", "{S}Hand"), ("{s}hand", "palm", None)],
        sides=("l", "r"), up="z", fingers=[["{s}fingers"], ["{s}thumb"]]),
    "bandai_standing": lambda: humanoid(
        "Hips", [("Spine", "Spine"), ("Chest", "Spine1")], [("Neck", "Neck"), ("Head", "Head")],
        [("UpperLeg_{s}", "thigh", "{S}UpLeg"), ("LowerLeg_{s}", "knee", "{S}Leg"), ("Foot_{s}", "ankle", "{S}Foot"),
         ("Toes_{s}", "toe", "{S}ToeBase")],
        [("Shoulder_{s}", "clav", "{S}Shoulder"), ("UpperArm_{s}", "arm", "{S}Arm"), ("LowerArm_{s}", "fore", "{S}ForeArm"),
         ("Hand_{s}", "wrist", "{S}Hand")], sides=("L", "R"), root="joint_Root"),
    "daz_shared_pelvis_twist_in_chain": lambda: humanoid(
        "hip", [("abdomenLower", "LowerBack"), ("abdomenUpper", "Spine"), ("chestLower", None), ("chestUpper", "Spine1")],
        [("neckLower", "Neck"), ("neckUpper", "Neck1"), ("head", "Head")],
        [("{s}ThighBend", "thigh", "{S}UpLeg"), ("{s}ThighTwist", "thigh2", None), ("{s}Shin", "knee", "{S}Leg"),
         ("{s}Foot", "ankle", "{S}Foot"), ("{s}Toe", "toe", "{S}ToeBase")],
        [("{s}Collar", "clav", "{S}Shoulder"), ("{s}ShldrBend", "arm", "{S}Arm"), ("{s}ShldrTwist", "arm2", None),
         ("{s}ForearmBend", "fore", "{S}ForeArm"), ("{s}ForearmTwist", "fore2", None), ("{s}Hand", "wrist", "{S}Hand")],
        sides=("l", "r"), pelvis="pelvis"),
    "optitrack_ab_chest": lambda: humanoid(
        "Hips", [("Ab", "Spine"), ("Chest", "Spine1")], [("Neck", "Neck"), ("Head", "Head")],
        [("{s}Thigh", "thigh", "{S}UpLeg"), ("{s}Shin", "knee", "{S}Leg"), ("{s}Foot", "ankle", "{S}Foot"),
         ("{s}Toe", "toe", "{S}ToeBase")],
        [("{s}Shoulder", "clav", "{S}Shoulder"), ("{s}UArm", "arm", "{S}Arm"), ("{s}FArm", "fore", "{S}ForeArm"),
         ("{s}Hand", "wrist", "{S}Hand")]),
    "no_names_facing_minus_z": lambda: humanoid(  # sides from the rest pose: left = up x forward
        "j0", [("j1", "LowerBack"), ("j2", "Spine"), ("j3", "Spine1")], [("j4", "Neck"), ("j5", "Head")],
        [("{s}1", "thigh", "{S}UpLeg"), ("{s}2", "knee", "{S}Leg"), ("{s}3", "ankle", "{S}Foot"), ("{s}4", "toe", "{S}ToeBase")],
        [("{s}5", "clav", "{S}Shoulder"), ("{s}6", "arm", "{S}Arm"), ("{s}7", "fore", "{S}ForeArm"), ("{s}8", "wrist", "{S}Hand")],
        sides=("a", "b"), facing=-1),
}


@pytest.mark.parametrize("convention", sorted(CONVENTIONS))
def test_each_convention_maps_as_a_person_would(convention):
    built, expected = CONVENTIONS[convention]()
    sk = read_bvh(f"{convention}.bvh", text=bvh_text(built), length_unit=0.01).skeleton
    found = map_from_tree(sk, f"{convention}.bvh")
    assert found.mapping == expected
    assert consistent(sk, found.mapping)
    assert found.made_up == [c for c in CCNET_25_JOINTS if c not in expected.values()]
    assert set(found.composed) | set(found.skipped) | set(found.mapping) == set(sk.names)
    assert not set(found.composed) & set(found.skipped)


def test_composed_and_skipped_joints_are_the_right_ones():
    sk, _ = CONVENTIONS["blender_rigify_z_up"]()
    found = map_from_tree(sk)
    assert found.composed == {"DEF-thigh.L.001": "LeftLeg", "DEF-shin.L.001": "LeftFoot",
                              "DEF-upper_arm.L.001": "LeftForeArm", "DEF-forearm.L.001": "LeftHand",
                              "DEF-thigh.R.001": "RightLeg", "DEF-shin.R.001": "RightFoot",
                              "DEF-upper_arm.R.001": "RightForeArm", "DEF-forearm.R.001": "RightHand"}
    assert {"DEF-pelvis.L", "DEF-breast.R", "DEF-palm.01.L", "DEF-f_index.02.R", "DEF-thumb.01.L"} <= set(found.skipped)
    sk, _ = CONVENTIONS["xsens_mvn"]()
    assert map_from_tree(sk).composed == {"T12": "Spine1"}
    sk, _ = CONVENTIONS["unreal_mannequin_z_up"]()
    found = map_from_tree(sk)
    assert found.skipped[0] == "root" and "ik_foot_l" in found.skipped and "calf_twist_01_r" in found.skipped
    assert found.made_up == ["LHipJoint", "RHipJoint", "Neck1"]


def test_the_table_lists_every_ccnet_joint():
    sk, _ = CONVENTIONS["xsens_mvn"]()
    lines = map_from_tree(sk).table().splitlines()
    assert lines[0] == "mapping found by: the tree and the rest pose"
    assert lines[1].split() == ["file", "joint", "CCNet", "joint"]
    rows = [line.split() for line in lines[2:27]]
    assert [r[-1] for r in rows] == list(CCNET_25_JOINTS)
    assert rows[1] == ["(made", "up)", "LHipJoint"] and rows[2] == ["LeftUpperLeg", "LeftUpLeg"]
    assert lines[27] == "composed (rotation carried by the CCNet joint): T12 -> Spine1"


def test_sides_from_names_need_a_partner():
    names = {"LeftArm", "RightArm", "lowerback", "lfemur", "rfemur", "thigh_l", "thigh_r", "DEF-toe.L", "DEF-toe.R"}
    assert [side_of(n, names) for n in ("LeftArm", "RightArm", "lowerback", "lfemur", "thigh_r", "DEF-toe.L")] == \
        [1, -1, 0, 1, -1, 1]


def test_mirrored_names_win_over_geometry_and_geometry_decides_without_them():
    sk, expected = CONVENTIONS["no_names_facing_minus_z"]()
    left_thigh = sk.rest_positions()[sk.index("a1")]
    assert left_thigh[0] < 0  # facing -Z, the body's left is -X
    assert map_from_tree(sk).mapping["a1"] == "LeftUpLeg"
    sk, expected = CONVENTIONS["unreal_mannequin_z_up"]()  # facing +Y with Z up: left at -X, named _l
    assert sk.rest_positions()[sk.index("thigh_l")][0] < 0 and map_from_tree(sk).mapping["thigh_l"] == "LeftUpLeg"


def _quadruped() -> Skeleton:
    """A dog-like tree (Y up, facing +Z): back legs, a tail, a spine to the front legs and head."""
    joints = [("Pelvis", None, (0, 60, 0)), ("Tail1", "Pelvis", (0, 62, -10)), ("Tail2", "Tail1", (0, 60, -30)),
              ("Spine", "Pelvis", (0, 62, 20)), ("Chest", "Spine", (0, 62, 50)), ("Neck", "Chest", (0, 75, 60)),
              ("Head", "Neck", (0, 85, 70))]
    for s, x in (("L", 8), ("R", -8)):
        joints += [(f"Thigh_{s}", "Pelvis", (x, 55, 0)), (f"Hock_{s}", f"Thigh_{s}", (x, 30, -5)),
                   (f"BackPaw_{s}", f"Hock_{s}", (x, 3, 0)), (f"Shoulder_{s}", "Chest", (x, 55, 50)),
                   (f"Elbow_{s}", f"Shoulder_{s}", (x, 30, 50)), (f"FrontPaw_{s}", f"Elbow_{s}", (x, 3, 52))]
    order = [n for n, _, _ in joints]
    pos = {n: np.array(p, float) * 0.01 for n, _, p in joints}
    parents = [order.index(p) if p else -1 for _, p, _ in joints]
    offsets = [pos[n] - (pos[p] if p else 0) for n, p, _ in joints]
    return Skeleton(tuple(order), parents, np.array(offsets), ((order.index("Head"), (0, 0, 0.1)),))


def test_a_quadruped_is_refused_with_what_was_found():
    with pytest.raises(NotHumanoidError) as err:
        map_skeleton(_quadruped(), source="dog.bvh")
    msg = str(err.value)
    assert msg.startswith("dog.bvh: not a humanoid skeleton: the two lowest chains outside the torso")
    assert "do not hang below the hips 'Pelvis'" in msg and "Tail2" in msg and "--joint-map FILE.json" in msg
    assert isinstance(err.value, SkeletonMapError)


def test_a_hand_only_is_refused():
    names = ["RightHand"] + [f"RightHand{f}{i}" for f in ("Thumb", "Index", "Middle", "Ring", "Pinky") for i in (1, 2, 3)]
    parents = [-1] + [0 if i % 3 == 0 else i for i in range(15)]
    sk = Skeleton(tuple(names), parents, np.tile([0.0, 0.0, 0.02], (16, 1)))
    with pytest.raises(NotHumanoidError, match=r"hand.bvh: not a humanoid skeleton: 1 core chain end\(s\)"):
        map_skeleton(sk, source="hand.bvh")


def test_name_tables_come_first_and_an_explicit_map_overrides_the_tree(tmp_path):
    sk, _ = CONVENTIONS["mixamo_fingers_y_up"]()
    assert map_skeleton(sk).method == "joint names (mixamo convention)"
    sk, expected = CONVENTIONS["xsens_mvn"]()
    assert map_skeleton(sk).mapping == expected and map_skeleton(sk).method == "the tree and the rest pose"
    over = map_skeleton(sk, {"T12": "Spine", "L3": None})  # the user's choice takes Spine from L3
    assert over.mapping["T12"] == "Spine" and "L3" not in over.mapping and over.composed["L3"] == "Spine"
    assert over.method == "the tree and the rest pose, with the explicit map over it"
    with pytest.raises(SkeletonMapError, match="not CCNet joints"):
        map_skeleton(sk, {"T12": "Chest"})
    with pytest.raises(SkeletonMapError, match=r"^dog.bvh: could not place"):
        map_skeleton(_quadruped(), {"Tail1": None}, source="dog.bvh")


@pytest.mark.skipif(DATA_DIR is None, reason="no real motion data")
@pytest.mark.parametrize("source", ["cmu", "hdm05", "bandai"])
def test_real_files_map_as_before(source):
    if not (DATA_DIR / source).is_dir():
        pytest.skip(f"no {source} data")
    if source == "hdm05":
        sk = read_asf(sorted((DATA_DIR / "hdm05").glob("*/*.asf"))[0]).to_skeleton()
    else:
        sk = read_bvh(sorted((DATA_DIR / source).glob("*/*.bvh"))[0]).skeleton
    by_name = map_to_ccnet25(sk.names)
    assert map_skeleton(sk).mapping == by_name
    if source == "bandai":  # its rest pose lies along X (rotations stand it up): names map it
        with pytest.raises(NotHumanoidError, match="a lying rest pose"):
            map_from_tree(sk)
    else:
        assert map_from_tree(sk).mapping == by_name
        assert sorted(by_name.values()) == sorted(CCNET_25_JOINTS)


def _walking_seed(convention: str, frames: int = 120):
    """A convention's skeleton at rest, its root moving forward at 0.72 m/s, 60 fps."""
    sk, _ = CONVENTIONS[convention]()
    head = bvh_text(sk).split("MOTION")[0]
    n_chan = 6 + 3 * (sk.n_joints - 1)
    axis = 1 if "z_up" in convention else 2  # forward: -Y with Z up (the BVH holds cm), +Z with Y up
    rows = []
    for i in range(frames):
        v = np.zeros(n_chan)
        v[axis] = (-1 if axis == 1 else 1) * 1.2 * i
        rows.append(" ".join(f"{x:.2f}" for x in v))
    text = head + f"MOTION\nFrames: {frames}\nFrame Time: {1 / 60:.6f}\n" + "\n".join(rows) + "\n"
    return read_bvh(f"{convention}.bvh", text=text, length_unit=0.01, up="z" if "z_up" in convention else "y")


@pytest.mark.parametrize("convention", ["axis_neuron_fingers", "daz_shared_pelvis_twist_in_chain",
                                        "unreal_mannequin_z_up"])
def test_tree_mapped_files_generate_on_their_own_skeleton(convention):
    from data_prep import zoo
    from mocapviz.tasks.generate_bvh import generate_from_seed
    from mocapviz.training.checkpoint import load_checkpoint

    seed = _walking_seed(convention)
    result = generate_from_seed(seed, *load_checkpoint(zoo.committed_path("ccnet_default")), seconds=1.0,
                                seed_seconds=1.0)
    assert result.motion.n_frames == 120 and result.motion.skeleton.names == seed.skeleton.names
    src = result.rig.source
    in_file = result.motion.positions()[result.n_seed:][:, src[src >= 0]]
    assert np.abs(in_file - result.model_motion.positions()[:, src >= 0]).max() < 1e-4
    made_up = {n for n, s in zip(result.rig.names, src) if s < 0}
    assert made_up == {"axis_neuron_fingers": {"LHipJoint", "RHipJoint", "LeftToeBase", "RightToeBase"},
                       "daz_shared_pelvis_twist_in_chain": {"LHipJoint", "RHipJoint"},
                       "unreal_mannequin_z_up": {"LHipJoint", "RHipJoint", "Neck1"}}[convention]
