"""Skeletons of many exporters placed on CCNet's 25 joints from the tree and the rest pose.

Each convention is a small hierarchy written in ``tests/fixtures/conventions.py`` (no
third-party file is copied), with the CCNet joint a person would give each joint (None:
composed into the CCNet joint below it, or skipped). Then the real files of the data folder
map as they did by name.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import DATA_DIR
from fixtures.conventions import CONVENTIONS, bvh_text
from mocapviz.io.asfamc import read_asf
from mocapviz.io.bvh import read_bvh
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton, SkeletonMapError, map_to_ccnet25
from mocapviz.skeleton_map import NotHumanoidError, consistent, map_from_tree, map_skeleton, side_of


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
