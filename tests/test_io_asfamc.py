"""ASF/AMC reader: a hand-made skeleton with known FK, HDM05 quirks and sanity, errors."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.errors import MocapFormatError
from mocapviz.io.asfamc import read_amc, read_asf
from mocapviz.skeleton import ASF_TO_VICON_BVH

INCH = 0.0254
# `angle rad`, a root order other than the default, an axis in radians, 1-dof bones.
ASF_RAD = """# test skeleton
:version 1.10
:name test
:units
  mass 1.0
  length 1.0
  angle rad
:root
   order RX RY RZ TX TY TZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name femur
     direction 0 0 1
     length 10
     axis 0 0 1.5707963267948966 XYZ
     dof rx
  end
  begin
     id 2
     name tibia
     direction 1 0 0
     length 5
     axis 0 0 0 XYZ
     dof rz
  end
  begin
     id 3
     name foot
     direction 0 1 0
     length 2
     axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root femur
    femur tibia
    tibia foot
  end
"""
HALF_PI = "1.5707963267948966"
AMC_RAD = f""":FULLY-SPECIFIED
:RADIANS
1
root 0 0 0 1 2 3
femur {HALF_PI}
tibia 0.5
2
root 0 {HALF_PI} 0 1 2 3
femur {HALF_PI}
tibia 0.5
"""


def test_asf_units_axis_dof_and_offsets():
    asf = read_asf("t.asf", text=ASF_RAD)
    assert not asf.angle_in_degrees
    assert asf.root_order == ["rx", "ry", "rz", "tx", "ty", "tz"]
    assert asf.length_unit == pytest.approx(INCH)
    assert asf.bones["femur"].dof == ["rx"] and asf.bones["tibia"].dof == ["rz"]
    np.testing.assert_allclose(asf.axis_matrix("femur") @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    sk = asf.to_skeleton()
    assert sk.names == ("root", "femur", "tibia", "foot")
    assert list(sk.parents) == [-1, 0, 1, 2]
    # a joint sits where its bone starts: tibia at the femur's end, foot at the tibia's end
    np.testing.assert_allclose(sk.offsets, np.array([[0, 0, 0], [0, 0, 0], [0, 0, 10], [5, 0, 0]]) * INCH)
    np.testing.assert_allclose(sk.bone_lengths(), np.array([0, 0, 10, 5]) * INCH)
    assert sk.end_sites[0][0] == 3
    np.testing.assert_allclose(sk.end_sites[0][1], np.array([0, 2, 0]) * INCH)


def test_amc_hand_computed_fk():
    asf = read_asf("t.asf", text=ASF_RAD)
    m = read_amc("t.amc", asf, fps=60, text=AMC_RAD)
    assert m.n_frames == 2 and m.fps == 60
    root = np.array([1, 2, 3]) * INCH  # root order puts the translation last
    np.testing.assert_allclose(m.root_positions, [root, root])
    pos = m.positions()
    # frame 1: femur rx = 90 deg about its axis C = Rz(90), i.e. about world +Y: +Z -> +X.
    tibia = root + np.array([10, 0, 0]) * INCH
    # tibia rz = 0.5 rad: its +X -> (cos .5, sin .5, 0); then the femur's Ry(90): (x,y,z)->(z,y,-x)
    foot = tibia + 5 * INCH * np.array([0, np.sin(0.5), -np.cos(0.5)])
    np.testing.assert_allclose(pos[0], [root, root, tibia, foot], atol=1e-12)
    # frame 2: root ry = 90 deg adds another Ry(90): femur turns 180 deg about Y in all
    tibia2 = root + np.array([0, 0, -10]) * INCH
    # Ry(90) applied to (0, sin .5, -cos .5) gives (-cos .5, sin .5, 0)
    foot2 = tibia2 + 5 * INCH * np.array([-np.cos(0.5), np.sin(0.5), 0])
    np.testing.assert_allclose(pos[1], [root, root, tibia2, foot2], atol=1e-12)


def test_degrees_and_radians_agree():
    asf_rad = read_asf("t.asf", text=ASF_RAD)
    asf_deg = read_asf("t.asf", text=ASF_RAD.replace("angle rad", "angle deg").replace("1.5707963267948966", "90"))
    amc_deg = AMC_RAD.replace(":RADIANS\n", ":DEGREES\n").replace(HALF_PI, "90").replace("0.5", str(np.degrees(0.5)))
    a = read_amc("t.amc", asf_rad, text=AMC_RAD)
    b = read_amc("t.amc", asf_deg, text=amc_deg)
    np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-12)


def test_length_unit_from_units_section():
    asf = read_asf("t.asf", text=ASF_RAD.replace("length 1.0", "length 0.45"))
    assert asf.length_unit == pytest.approx(INCH / 0.45)


def test_root_angles_beyond_360_same_rotation(hdm05_files, hdm05_asf):
    path = next(p for p in hdm05_files if p.name == "HDM_bd_depositFloorR_005_120.amc")
    text = path.read_bytes().decode("latin-1")
    m = read_amc(path, hdm05_asf(path))
    roots = [line.split() for line in text.splitlines() if line.startswith("root ")]
    assert max(abs(float(v)) for r in roots for v in r[4:]) > 360  # the quirk is in this file
    shifted = "\n".join(
        "root " + " ".join(r[1:4] + [repr(float(v) - 720.0) for v in r[4:]]) if line.startswith("root ") else line
        for line, r in ((line, line.split()) for line in text.splitlines()))
    m2 = read_amc(path, hdm05_asf(path), text=shifted)
    np.testing.assert_allclose(m2.rotations, m.rotations, atol=1e-9)


def test_latin1_comment_line(hdm05_files, hdm05_asf):
    path = next(p for p in hdm05_files if p.parent.name == "bd")
    raw = path.read_bytes()
    with pytest.raises(UnicodeDecodeError):
        raw.decode("utf-8")
    m = read_amc(path, hdm05_asf(path))
    assert m.n_frames == sum(1 for line in raw.splitlines() if line.strip().isdigit())


def test_hdm05_bone_lengths_match_asf(hdm05_files, hdm05_asf):
    for actor in sorted({p.parent.name for p in hdm05_files}):
        amc = next(p for p in hdm05_files if p.parent.name == actor)
        asf = hdm05_asf(amc)
        assert asf.length_unit == pytest.approx(INCH / 0.45)
        sk = asf.to_skeleton()
        for j in range(1, sk.n_joints):
            parent_bone = asf.bones[sk.names[sk.parents[j]]]
            # ASF directions are unit vectors to ~6 digits
            assert sk.bone_lengths()[j] == pytest.approx(parent_bone.length * asf.length_unit, rel=1e-5)
        m = read_amc(amc, asf)
        pos = m.positions()
        seg = np.linalg.norm(pos[:, 1:] - pos[:, sk.parents[1:]], axis=-1)
        np.testing.assert_allclose(seg, np.broadcast_to(sk.bone_lengths()[1:], seg.shape), atol=1e-6)


def test_hdm05_feet_on_floor_and_upright(hdm05_files, hdm05_asf):
    """Y is up and the floor is y = 0: a wrong axis order, unit or dof order breaks this."""
    for path in hdm05_files[::7]:
        m = read_amc(path, hdm05_asf(path))
        m.skeleton = m.skeleton.renamed(ASF_TO_VICON_BVH)
        pos = m.positions()
        names = m.skeleton.names
        feet = [names.index(n) for n in ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase")]
        lowest = pos[:, feet, 1].min(axis=1)
        floor = np.percentile(lowest, 5)
        assert -0.03 < floor < 0.07, (path.name, floor)
        assert np.mean(np.abs(lowest - floor) < 0.05) > 0.25, path.name
        trunk = pos[:, names.index("Head")] - pos[:, names.index("Hips")]
        if "lieDown" not in path.name:  # stands upright (trunk along +Y) for part of the clip
            upright = trunk[:, 1] / np.linalg.norm(trunk, axis=1)
            assert np.percentile(upright, 90) > 0.8, (path.name, np.percentile(upright, 90))


# ---- malformed input ----

def _amc_lines():
    return AMC_RAD.split("\n")  # 1-based: 3 "1", 4 root, 5 femur, 6 tibia, 7 "2", 8 root, 9 femur, 10 tibia


AMC_BAD = {
    "too_many_values": (lambda L: L[:4] + ["femur 1 2"] + L[5:], 5),
    "too_few_values": (lambda L: L[:3] + ["root 0 0 0 1 2"] + L[4:], 4),
    "unknown_joint": (lambda L: L[:8] + ["knee 0.1"] + L[9:], 9),
    "not_a_number": (lambda L: L[:5] + ["tibia 0.5x"] + L[6:], 6),
    "inf": (lambda L: L[:5] + ["tibia inf"] + L[6:], 6),
    "duplicate_joint": (lambda L: L[:6] + ["tibia 0.1"] + L[6:], 7),
    "truncated": (lambda L: L[:9], 7),
    "values_before_frame": (lambda L: L[:2] + L[3:], 3),
}


@pytest.mark.parametrize("case", sorted(AMC_BAD))
def test_malformed_amc_names_file_and_line(case):
    make, line = AMC_BAD[case]
    asf = read_asf("t.asf", text=ASF_RAD)
    with pytest.raises(MocapFormatError) as err:
        read_amc("bad.amc", asf, text="\n".join(make(_amc_lines())))
    assert err.value.path == "bad.amc" and "bad.amc" in str(err.value)
    assert err.value.line == line, str(err.value)


@pytest.mark.parametrize("old,new,line", [
    ("    tibia foot\n", "    tibia toe\n", 41),
    ("     dof rz\n", "     dof rq\n", 28),
    ("  angle rad\n", "  angle grad\n", 7),
    ("     direction 1 0 0\n", "     direction 1 0\n", 25),
])
def test_malformed_asf_names_file_and_line(old, new, line):
    assert old in ASF_RAD
    with pytest.raises(MocapFormatError) as err:
        read_asf("bad.asf", text=ASF_RAD.replace(old, new))
    assert err.value.path == "bad.asf" and err.value.line == line, str(err.value)


def test_truncated_asf():
    with pytest.raises(MocapFormatError, match="truncated"):
        read_asf("bad.asf", text=ASF_RAD[:ASF_RAD.index("     dof rz")])
