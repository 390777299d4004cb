"""Joint names of real files' conventions mapped onto the CCNet 25-joint topology.

Real files: CMU BVH (MotionBuilder-friendly names), HDM05 ASF (VICON names), Bandai. The
3dsMax-friendly CMU names and Mixamo's are not in the data folder: those two are small
hand-written BVH hierarchies below, with the joint names and nesting those exporters write.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import DATA_DIR
from mocapviz.io.asfamc import read_asf
from mocapviz.io.bvh import read_bvh
from mocapviz.skeleton import CCNET_25_JOINTS, SkeletonMapError, map_to_ccnet25


def _bvh(tree) -> str:
    """BVH text (one frame of zeros) for a nested (name, [children]) tree; offsets are dummies."""
    lines, n_chan = ["HIERARCHY"], [0]

    def emit(node, depth, root=False):
        name, kids = node
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if root else 'JOINT'} {name}\n{pad}{{\n{pad}  OFFSET 0 {0 if root else 10} 0")
        lines.append(f"{pad}  CHANNELS {6 if root else 3} " + ("Xposition Yposition Zposition " if root else "")
                     + "Zrotation Xrotation Yrotation")
        n_chan[0] += 6 if root else 3
        for k in kids:
            emit(k, depth + 1)
        if not kids:
            lines.append(f"{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0 5 0\n{pad}  }}")
        lines.append(f"{pad}}}")
    emit(tree, 0, root=True)
    return "\n".join(lines) + f"\nMOTION\nFrames: 1\nFrame Time: 0.033333\n{' '.join(['0'] * n_chan[0])}\n"


def _chain(*names):
    node = (names[-1], [])
    for n in reversed(names[:-1]):
        node = (n, [node])
    return node


def _limbs(side, names):
    return _chain(*[n.format(side=side) for n in names])


MAX_3DS = ("Hips", [
    ("Chest", [("Chest2", [("Chest3", [("Chest4", [
        _chain("Neck", "Head"),
        *[_limbs(s, ["{side}Collar", "{side}Shoulder", "{side}Elbow", "{side}Wrist"]) for s in ("Right", "Left")]])])])]),
    *[_limbs(s, ["{side}Hip", "{side}Knee", "{side}Ankle", "{side}Toe"]) for s in ("Right", "Left")]])

_FINGERS = [_chain(*[f"mixamorig:{{side}}Hand{f}{k}" for k in range(1, 5)]) for f in ("Thumb", "Index", "Middle")]
MIXAMO = ("mixamorig:Hips", [
    ("mixamorig:Spine", [("mixamorig:Spine1", [("mixamorig:Spine2", [
        _chain("mixamorig:Neck", "mixamorig:Head", "mixamorig:HeadTop_End"),
        *[(f"mixamorig:{s}Shoulder", [(f"mixamorig:{s}Arm", [(f"mixamorig:{s}ForeArm", [(f"mixamorig:{s}Hand", [
            (f[0].format(side=s), [(f[1][0][0].format(side=s), [])]) for f in _FINGERS])])])])
          for s in ("Left", "Right")]])])]),
    *[_limbs(s, ["mixamorig:{side}UpLeg", "mixamorig:{side}Leg", "mixamorig:{side}Foot",
                 "mixamorig:{side}ToeBase", "mixamorig:{side}Toe_End"]) for s in ("Left", "Right")]])


@pytest.fixture(scope="module")
def ccnet_parents(cmu_files):
    """The CCNet 25-joint tree, as the CMU skeleton restricted to those joints."""
    sk = read_bvh(cmu_files[0]).skeleton.keep_joints(CCNET_25_JOINTS)[0]
    return {n: (sk.names[sk.parents[j]] if sk.parents[j] >= 0 else None) for j, n in enumerate(sk.names)}


def _assert_tree_consistent(skeleton, mapping, ccnet_parents):
    """Each mapped joint's nearest mapped ancestor maps to an ancestor of its CCNet joint."""
    def ccnet_ancestors(n):
        out = []
        while (n := ccnet_parents[n]) is not None:
            out.append(n)
        return out
    for j, name in enumerate(skeleton.names):
        if name not in mapping:
            continue
        p = skeleton.parents[j]
        while p >= 0 and skeleton.names[p] not in mapping:
            p = skeleton.parents[p]
        if p >= 0:
            assert mapping[skeleton.names[p]] in ccnet_ancestors(mapping[name]), (name, mapping[name])


def test_cmu_bvh_names_map_to_themselves(cmu_files, ccnet_parents):
    sk = read_bvh(cmu_files[0]).skeleton
    m = map_to_ccnet25(sk.names)
    assert m == {n: n for n in CCNET_25_JOINTS}  # the six hand joints are skipped
    _assert_tree_consistent(sk, m, ccnet_parents)


def test_hdm05_asf_names(hdm05_files, ccnet_parents):
    sk = read_asf(hdm05_files[0].parent / f"HDM_{hdm05_files[0].parent.name}.asf").to_skeleton()
    m = map_to_ccnet25(sk.names)
    assert sorted(m.values()) == sorted(CCNET_25_JOINTS)
    assert m["root"] == "Hips" and m["lfemur"] == "LeftUpLeg" and m["rclavicle"] == "RightShoulder"
    _assert_tree_consistent(sk, m, ccnet_parents)


@pytest.mark.skipif(DATA_DIR is None or not (DATA_DIR / "bandai").is_dir(), reason="no bandai data")
def test_bandai_names(ccnet_parents):
    path = sorted((DATA_DIR / "bandai").glob("*/*.bvh"))[0]
    sk = read_bvh(path).skeleton
    m = map_to_ccnet25(sk.names)
    assert set(sk.names) - set(m) == {"joint_Root"}  # the reference root is skipped
    assert m["UpperLeg_L"] == "LeftUpLeg" and m["Toes_R"] == "RightToeBase" and m["Chest"] == "Spine1"
    # the 25 joints Bandai has no counterpart for
    assert set(CCNET_25_JOINTS) - set(m.values()) == {"LHipJoint", "RHipJoint", "LowerBack", "Neck1"}
    _assert_tree_consistent(sk, m, ccnet_parents)


@pytest.mark.parametrize("tree", [MAX_3DS, MIXAMO], ids=["cmu_3dsmax", "mixamo"])
def test_hand_written_conventions(tree, ccnet_parents):
    sk = read_bvh("x.bvh", text=_bvh(tree), length_unit=0.01).skeleton
    m = map_to_ccnet25(sk.names)
    _assert_tree_consistent(sk, m, ccnet_parents)
    legs = {v for v in m.values() if "Leg" in v or "Foot" in v or "Toe" in v}
    assert legs == {f"{s}{p}" for s in ("Left", "Right") for p in ("UpLeg", "Leg", "Foot", "ToeBase")}
    assert {"Hips", "Spine", "Spine1", "Neck", "Head", "LeftHand", "RightForeArm"} <= set(m.values())
    if tree is MIXAMO:
        assert m["mixamorig:LeftArm"] == "LeftArm" and "mixamorig:LeftHandIndex2" not in m
    else:  # 3dsMax's "Shoulder" is the upper arm, its "Collar" the clavicle
        assert m["LeftShoulder"] == "LeftArm" and m["LeftCollar"] == "LeftShoulder"


def test_unknown_joints_are_named_and_an_explicit_json_map_places_them(tmp_path):
    names = [n for n in CCNET_25_JOINTS if n != "LeftLeg"] + ["LeftShin", "Tail"]
    with pytest.raises(SkeletonMapError) as err:
        map_to_ccnet25(names)
    msg = str(err.value)
    assert "LeftShin, Tail" in msg and "explicit map" in msg and "JSON" in msg
    path = tmp_path / "map.json"
    path.write_text(json.dumps({"LeftShin": "LeftLeg", "Tail": None}))
    m = map_to_ccnet25(names, explicit=path)
    assert m["LeftShin"] == "LeftLeg" and "Tail" not in m and len(m) == 25
    with pytest.raises(SkeletonMapError, match="not CCNet joints"):
        map_to_ccnet25(names, explicit={"Tail": "Tail"})
    with pytest.raises(SkeletonMapError, match="several joints map to"):
        map_to_ccnet25(names, explicit={"LeftShin": "LeftLeg", "Tail": "LeftLeg"})
    assert np.array_equal(sorted(m.values()), sorted(CCNET_25_JOINTS))
