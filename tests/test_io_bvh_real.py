"""BVH files as real exporters write them, against an independent reference FK.

The reference below parses the file its own way (a token walk) and composes each joint's
transform with scipy: global_j = global_parent @ T(t_j) @ R_j, where t_j is the joint's
OFFSET with any position channel replacing its component (the rule bvhio and Blender's
importer follow; checked against bvhio on a Bandai take to 6e-5 cm, its float32 precision).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import DATA_DIR
from mocapviz.io.axes import Z_UP_TO_Y_UP
from mocapviz.io.bvh import read_bvh, write_bvh

BANDAI = sorted((DATA_DIR / "bandai").glob("*/*.bvh")) if DATA_DIR and (DATA_DIR / "bandai").is_dir() else []
needs_bandai = pytest.mark.skipif(not BANDAI, reason="no bandai folder in the data folder")
# a walk, a turn, a run, a side step and a take whose reference root moves (not static)
PICKS = ["dataset-2_walk_normal_001", "dataset-2_walk-turn-left_active_001", "dataset-2_run_youthful_001",
         "dataset-1_walk-left_happy_001", "dataset-1_dash_giant_001"]


def reference_fk(path) -> tuple[list[str], np.ndarray]:
    """Joint names and world positions (F, J, 3) in file units, computed independently."""
    tokens = path.read_text().split()
    names, parents, offsets, channels, stack = [], [], [], [], []
    i, in_end = 0, 0
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            i += 2
            continue
        if t == "End":
            in_end, i = 1, i + 2
            continue
        if t == "{":
            stack.append(len(names) - 1 if not in_end else -2)
        elif t == "}":
            in_end = 0 if stack.pop() == -2 else in_end
        elif t == "OFFSET" and stack[-1] != -2:
            offsets.append([float(v) for v in tokens[i + 1:i + 4]])
            i += 4
            continue
        elif t == "OFFSET":
            i += 4
            continue
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            channels.append([c.lower() for c in tokens[i + 2:i + 2 + n]])
            i += 2 + n
            continue
        i += 1
    n_frames = int(tokens[i + 2])
    start = i + 6  # MOTION Frames: N Frame Time: dt
    width = sum(len(c) for c in channels)
    values = np.array(tokens[start:start + n_frames * width], dtype=float).reshape(n_frames, width)
    glob_r, glob_p = [], []
    col = 0
    for j, chans in enumerate(channels):
        v = values[:, col:col + len(chans)]
        col += len(chans)
        t = np.tile(offsets[j], (n_frames, 1))
        for k, c in enumerate(chans):
            if c.endswith("position"):
                t[:, "xyz".index(c[0])] = v[:, k]
        rot_idx = [k for k, c in enumerate(chans) if c.endswith("rotation")]
        order = "".join(chans[k][0].upper() for k in rot_idx)
        r = Rotation.from_euler(order, v[:, rot_idx], degrees=True) if rot_idx else Rotation.identity(n_frames)
        if parents[j] < 0:
            glob_r.append(r)
            glob_p.append(t)
        else:
            glob_r.append(glob_r[parents[j]] * r)
            glob_p.append(glob_p[parents[j]] + glob_r[parents[j]].apply(t))
    return names, np.stack(glob_p, axis=1)


def travel(root: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(root[:, [0, 2]], axis=0), axis=1).sum())


@needs_bandai
@pytest.mark.parametrize("clip", PICKS)
def test_bandai_fk_equals_reference_with_and_without_the_reference_root(clip):
    path = next(p for p in BANDAI if p.stem == clip)
    names, ref = reference_fk(path)
    ref = ref * 0.01  # Bandai is in cm
    m = read_bvh(path)
    assert m.meta["length_unit"] == 0.01
    assert m.skeleton.names == tuple(names)
    np.testing.assert_allclose(m.positions(), ref, atol=1e-6)
    hips = names.index("Hips")
    assert travel(ref[:, hips]) > 0.5  # the take really goes somewhere
    folded = read_bvh(path, drop_static_root=True)
    static = (m.meta["channel_values"][:, :6] == m.meta["channel_values"][0, :6]).all()
    assert folded.skeleton.names[0] == ("Hips" if static else "joint_Root")
    moved = m.fold_root()  # folding is exact for a moving reference root too
    for motion in (folded, moved):
        k = motion.skeleton.names.index("Hips")
        np.testing.assert_allclose(motion.positions(), ref[:, len(names) - motion.skeleton.n_joints:], atol=1e-6)
        assert travel(motion.positions()[:, k]) == pytest.approx(travel(ref[:, hips]), abs=1e-6)


@needs_bandai
def test_bandai_write_read_round_trip_keeps_every_position():
    m = read_bvh(BANDAI[0], drop_static_root=True)
    assert m.translations  # Bandai's joints carry (tiny) per-frame translations
    back = read_bvh("again.bvh", text=write_bvh(m))
    assert back.skeleton.names == m.skeleton.names and back.meta["length_unit"] == 0.01
    np.testing.assert_allclose(back.positions(), m.positions(), atol=1e-7)
    assert 0 < len(back.translations) and set(back.translations) <= set(m.translations)  # some print as OFFSET
    # rigid() drops them (all within 1 mm of the rest offsets) and moves joints < 1 mm
    np.testing.assert_allclose(m.rigid().positions(), m.positions(), atol=3e-3)


@needs_bandai
def test_unit_guess_is_the_same_for_every_take_of_one_skeleton():
    # The Hips OFFSET of these files is a placement (the take's start), not a bone.
    units = {read_bvh(p).meta["length_unit"] for p in BANDAI[::25]}
    assert units == {0.01}


@needs_bandai
def test_z_up_file_reads_back_y_up():
    m = read_bvh(BANDAI[0], drop_static_root=True)
    z_up_text = write_bvh(m.rotated(Z_UP_TO_Y_UP.T))  # the same take, as a Z-up tool writes it
    raw = read_bvh("z.bvh", text=z_up_text)
    assert raw.meta["up"] == "y"
    np.testing.assert_allclose(raw.positions() @ Z_UP_TO_Y_UP.T, m.positions(), atol=1e-6)
    for up in ("z", "auto"):
        back = read_bvh("z.bvh", text=z_up_text, up=up)
        assert back.meta["up"] == "z" and "Z up -> Y up" in back.meta["axes"]
        np.testing.assert_allclose(back.positions(), m.positions(), atol=1e-6)
    assert read_bvh(BANDAI[0], up="auto").meta["up"] == "y"
    with pytest.raises(ValueError, match="up must be"):
        read_bvh(BANDAI[0], up="x")


@needs_bandai
def test_lenient_frame_count_and_blank_lines_on_a_real_file(tmp_path):
    text = BANDAI[0].read_text()
    head, frames = text.split("Frame Time:")
    n = int(head.split("Frames:")[1])
    frame_lines = frames.split("\n")[1:]
    extra = head + "Frame Time:" + frames.rstrip("\n") + "\n" + frame_lines[0] + "\n"  # one more line
    with pytest.warns(UserWarning, match=rf"Frames: {n}' but {n + 1} frame lines") as rec:
        m = read_bvh(tmp_path / "extra.bvh", text=extra)
    assert m.n_frames == n + 1 and "extra.bvh" in str(rec[0].message)
    # blank lines inside HIERARCHY, between MOTION and Frames, and odd spacing in headers
    loose = (text.replace("\n  JOINT", "\n\n  JOINT", 3).replace("MOTION\n", "MOTION\n\n \t\n")
             .replace("Frame Time:", "Frame  Time :"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = read_bvh(tmp_path / "loose.bvh", text=loose)
    np.testing.assert_array_equal(again.positions(), read_bvh(BANDAI[0]).positions())


# A root with only rotation channels, its translation on the child (seen in game exports).
ROOT_WITHOUT_POSITION = """HIERARCHY
ROOT Reference
{
  OFFSET 0 0 0
  CHANNELS 3 Zrotation Xrotation Yrotation
  JOINT Hips
  {
    OFFSET 0 90 0
    CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
    JOINT Spine
    {
      OFFSET 0 20 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 10 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
0 0 0 0 90 0 0 0 0 0 0 0
0 0 0 50 90 0 0 0 90 0 0 0
0 0 0 100 90 -20 0 0 0 0 90 0
"""


def test_translation_on_the_roots_child_moves_the_body(tmp_path):
    p = tmp_path / "child.bvh"
    p.write_text(ROOT_WITHOUT_POSITION)
    m = read_bvh(p, length_unit=0.01)
    _, ref = reference_fk(p)
    np.testing.assert_allclose(m.positions(), ref * 0.01, atol=1e-12)
    # hand-computed: frame 2 Hips at (1, 0.9, -0.2); frame 1 Hips turned 90 deg about Y: the
    # spine still points up; frame 2 Spine turned 90 deg about X: its end site is not a joint
    np.testing.assert_allclose(m.positions()[:, 1], [[0, 0.9, 0], [0.5, 0.9, 0], [1, 0.9, -0.2]], atol=1e-12)
    np.testing.assert_allclose(m.positions()[:, 2], [[0, 1.1, 0], [0.5, 1.1, 0], [1, 1.1, -0.2]], atol=1e-12)
    assert travel(m.positions()[:, 1]) == pytest.approx(0.5 + np.hypot(0.5, 0.2), abs=1e-12)
    folded = read_bvh(p, length_unit=0.01, drop_static_root=True)
    assert folded.skeleton.names == ("Hips", "Spine")
    np.testing.assert_allclose(folded.root_positions, m.positions()[:, 1], atol=1e-12)


@needs_bandai
def test_heights_of_a_lying_rest_skeleton_come_from_its_bones():
    # Bandai's rest skeleton lies along X (its rotations stand it up): heights from the rest
    # pose are meaningless; the bone chains give the posed head height's order of magnitude.
    m = read_bvh(BANDAI[0], drop_static_root=True)
    head = m.positions()[:, m.skeleton.index("Head"), 1].max() - m.positions()[..., 1].min()
    for sk in (m.skeleton, read_bvh(BANDAI[0]).skeleton):  # with or without the reference root
        assert sk.standing_height() == sk.height_from_bones()
        assert 0.9 * head < sk.standing_height() < 1.1 * head


@needs_bandai
def test_consumers_of_fk_keep_joint_translations():
    """Foot locking and the end-site geometry run FK through ``Motion.global_pose``: on a raw
    Bandai take (the trajectory in Hips' position channels, below ``joint_Root``) foot locking
    with no contact frames changes nothing, and end sites hang off the travelling joints."""
    from mocapviz.ik import remove_foot_sliding
    from mocapviz.viz.geometry import end_site_segments

    m = read_bvh(BANDAI[0])
    assert m.translations, "the raw take keeps Hips' channels as joint translations"
    legs = (("UpperLeg_L", "LowerLeg_L", "Foot_L"), ("UpperLeg_R", "LowerLeg_R", "Foot_R"))
    out = remove_foot_sliding(m, np.zeros((m.n_frames, 2), dtype=bool), legs=legs)
    np.testing.assert_allclose(out.positions(), m.positions(), atol=1e-9)
    assert set(out.translations) == set(m.translations)
    seg = end_site_segments(m)
    pos = m.positions()
    joints = [j for j, _ in m.skeleton.end_sites]
    np.testing.assert_allclose(seg[:, :, 0], pos[:, joints], atol=1e-9)
