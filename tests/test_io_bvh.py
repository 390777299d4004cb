"""BVH reader and writer: hand-made files with known answers, real CMU round trips, errors."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.errors import MocapFormatError
from mocapviz.io._text import LENGTH_UNITS, fast_number_table
from mocapviz.io.bvh import read_bvh, write_bvh
from mocapviz.rotations import euler_to_matrix

# Root with rotations before positions, a joint in XZY order with 6 channels, an End Site,
# tabs, CRLF line ends, and a Frame Time rounded to 6 digits (1/30 s). Units: cm.
SMALL = (
    "HIERARCHY\r\n"
    "ROOT\tHips\r\n{\r\n"
    "\tOFFSET 0 0 0\r\n"
    "\tCHANNELS 6 Zrotation Xrotation Yrotation Xposition Yposition Zposition\r\n"
    "\tJOINT Chest\r\n\t{\r\n"
    "\t\tOFFSET 0 10 0\r\n"
    "\t\tCHANNELS 6 Xposition Yposition Zposition Xrotation Zrotation Yrotation\r\n"
    "\t\tJOINT Arm\r\n\t\t{\r\n"
    "\t\t\tOFFSET 20 0 0\r\n"
    "\t\t\tCHANNELS 3 Xrotation Zrotation Yrotation\r\n"
    "\t\t\tEnd Site\r\n\t\t\t{\r\n\t\t\t\tOFFSET 5 0 0\r\n\t\t\t}\r\n"
    "\t\t}\r\n"
    "\t}\r\n"
    "}\r\n"
    "MOTION\r\n"
    "Frames:\t2\r\n"
    "Frame Time: 0.033333\r\n"
    "0 0 0 100 200 300 0 10 0 0 0 0 0 0 0\r\n"
    "0 90 0 100 200 300 0 10 0 0 0 0 90 90 0\r\n"
)


def test_small_bvh_structure_units_and_fps():
    m = read_bvh("small.bvh", length_unit=0.01, text=SMALL)
    assert m.skeleton.names == ("Hips", "Chest", "Arm")
    assert list(m.skeleton.parents) == [-1, 0, 1]
    assert m.fps == 30.0 and m.n_frames == 2
    np.testing.assert_allclose(m.skeleton.offsets, [[0, 0, 0], [0, 0.1, 0], [0.2, 0, 0]])
    assert len(m.skeleton.end_sites) == 1 and m.skeleton.end_sites[0][0] == 2
    np.testing.assert_allclose(m.skeleton.end_sites[0][1], [0.05, 0, 0])
    np.testing.assert_allclose(m.root_positions, [[1, 2, 3], [1, 2, 3]])
    # the non-root 6-channel joint only repeats its OFFSET: it stays rigid (no translations)
    assert m.translations == {}


def test_small_bvh_hand_computed_fk():
    m = read_bvh("small.bvh", length_unit=0.01, text=SMALL)
    pos = m.positions()
    # frame 0: rest pose at the root translation
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [1, 2.1, 3], [1.2, 2.1, 3]], atol=1e-12)
    # frame 1: root Zrot 0, Xrot 90, Yrot 0 -> Rx(90) takes +Y to +Z: chest at (1, 2, 3.1).
    # Arm's frame = Rx(90); Arm offset (0.2,0,0) is unchanged by Rx: arm at (1.2, 2, 3.1).
    np.testing.assert_allclose(pos[1, :2], [[1, 2, 3], [1, 2, 3.1]], atol=1e-12)
    np.testing.assert_allclose(pos[1, 2], [1.2, 2, 3.1], atol=1e-12)
    # Arm rotation, channels "Xrotation Zrotation Yrotation" = 90 90 0: R = Rx(90) @ Rz(90).
    # Rz(90) maps +X to +Y, Rx(90) maps +Y to +Z: the arm's local +X points to +Z.
    r = m.rotations[1, 2]
    np.testing.assert_allclose(r @ [1, 0, 0], [0, 0, 1], atol=1e-12)
    # read as ZYX (the common order) the same numbers would give another rotation
    assert not np.allclose(r, euler_to_matrix(np.array([90.0, 90.0, 0.0]), "ZYX"))
    # in the world (root Rx(90) maps +Z to -Y) the arm points down
    world_arm = m.rotations[1, 0] @ m.rotations[1, 1] @ r
    np.testing.assert_allclose(world_arm @ [1, 0, 0], [0, -1, 0], atol=1e-12)


def test_frame_time_rounding():
    text = SMALL.replace("0.033333", "0.008333")
    assert read_bvh("x.bvh", text=text).fps == 120.0
    text = SMALL.replace("0.033333", "0.04")
    assert read_bvh("x.bvh", text=text).fps == 25.0


def test_small_round_trip_exact_text():
    m = read_bvh("small.bvh", length_unit=0.01, text=SMALL)
    out = write_bvh(m)
    again = read_bvh("again.bvh", length_unit=0.01, text=out)
    assert again.skeleton.names == m.skeleton.names
    np.testing.assert_allclose(again.rotations, m.rotations, atol=1e-12)
    np.testing.assert_allclose(again.root_positions, m.root_positions, atol=1e-12)
    np.testing.assert_allclose(again.meta["channel_values"], m.meta["channel_values"], atol=1e-9)
    assert again.meta["channels"] == m.meta["channels"]


def _motion_numbers(text: str) -> np.ndarray:
    head, _, body = text.partition("Frame Time:")
    body = body.split("\n", 1)[1]
    return np.array(body.split(), dtype=np.float64)


def _header_numbers(text: str) -> np.ndarray:
    head = text.split("MOTION")[0]
    return np.array([float(v) for line in head.splitlines() if line.split()[:1] == ["OFFSET"]
                     for v in line.split()[1:]])


@pytest.fixture(scope="module")
def cmu_texts(cmu_files):
    return [(p, p.read_text()) for p in cmu_files]


def test_cmu_write_read_round_trip_values(cmu_texts, tmp_path):
    for path, text in cmu_texts:
        m = read_bvh(path, length_unit=LENGTH_UNITS["cmu"])
        out = tmp_path / path.name
        written = write_bvh(m, out)
        back = read_bvh(out, length_unit=LENGTH_UNITS["cmu"])
        assert back.skeleton.names == m.skeleton.names
        assert np.array_equal(back.skeleton.parents, m.skeleton.parents)
        assert back.fps == m.fps == 120.0 and back.n_frames == m.n_frames
        np.testing.assert_allclose(back.skeleton.offsets, m.skeleton.offsets, atol=1e-6 * m.meta["length_unit"])
        np.testing.assert_allclose(back.rotations, m.rotations, atol=1e-7)
        np.testing.assert_allclose(back.positions(), m.positions(), atol=1e-6)
        # text level: every number of the rewritten file equals the original's to print precision
        orig, new = _motion_numbers(text), _motion_numbers(written)
        assert orig.shape == new.shape
        np.testing.assert_allclose(new, orig, rtol=0, atol=5e-7 + 1e-12 * np.abs(orig).max())
        np.testing.assert_allclose(_header_numbers(written), _header_numbers(text), rtol=0, atol=5e-6)


def test_cmu_round_trip_without_original_angles(cmu_texts):
    """Angles recomputed from matrices (no stored originals) still give the same motion."""
    for path, _ in cmu_texts[:5]:
        m = read_bvh(path, length_unit=LENGTH_UNITS["cmu"])
        del m.meta["channel_values"]
        back = read_bvh("re.bvh", length_unit=LENGTH_UNITS["cmu"], text=write_bvh(m))
        np.testing.assert_allclose(back.rotations, m.rotations, atol=1e-7)
        np.testing.assert_allclose(back.positions(), m.positions(), atol=1e-6)


def test_fast_number_parse_equals_python_float(cmu_texts, h36m_files):
    """The C fast path gives exactly float(token) for every value of every CMU file."""
    for path, text in cmu_texts:
        body = text.split("Frame Time:")[1].split("\n", 1)[1]
        fast = fast_number_table(body.encode())
        ref = np.array([float(t) for t in body.split()])
        assert np.array_equal(fast.ravel(), ref), path
    for path in h36m_files[::11]:
        body = path.read_text()
        fast = fast_number_table(body.replace(",", " ").encode())
        assert np.array_equal(fast.ravel(), np.array([float(t) for t in body.replace(",", " ").split()])), path


def test_cmu_root_angles_beyond_180(cmu_files):
    p = next(f for f in cmu_files if f.stem == "143_24")
    m = read_bvh(p)
    assert np.abs(m.meta["channel_values"][:, 3:6]).max() > 180
    assert np.isfinite(m.rotations).all()


# ---- malformed input: MocapFormatError naming the file and the line ----

def _lines(text):
    return text.replace("\r\n", "\n").split("\n")


def _join(lines):
    return "\n".join(lines)


# SMALL's lines (1-based): 4 root OFFSET, 13 Arm CHANNELS, 20 root "}", 21 MOTION,
# 22 Frames, 23 Frame Time, 24 and 25 the two frames. L[k] is line k + 1.
BAD_CASES = {
    # name: (make text from SMALL's lines, expected 1-based line)
    "too_many_values": (lambda L: _join(L[:24] + [L[24] + " 7"] + L[25:]), 25),
    "too_few_values": (lambda L: _join(L[:23] + [L[23].rsplit(" ", 1)[0]] + L[24:]), 24),
    "not_a_number": (lambda L: _join(L[:24] + [L[24].replace("90", "9O", 1)] + L[25:]), 25),
    "nan": (lambda L: _join(L[:24] + [L[24].replace("90", "nan", 1)] + L[25:]), 25),
    "underscore_number": (lambda L: _join(L[:23] + [L[23].replace("100", "1_00", 1)] + L[24:]), 24),
    "truncated_frames": (lambda L: _join(L[:24]), 24),
    "truncated_mid_line": (lambda L: _join(L[:24] + [L[24][:9]]), 25),
    "truncated_hierarchy": (lambda L: _join(L[:10]), 10),
    "extra_close_brace": (lambda L: _join(L[:20] + ["}"] + L[20:]), 21),
    "missing_close_brace": (lambda L: _join(L[:19] + L[20:]), 20),
    "bad_channel": (lambda L: _join(L[:12] + ["\t\t\tCHANNELS 3 Xrotation Zrotation Wrotation"] + L[13:]), 13),
    "channel_count": (lambda L: _join(L[:12] + ["\t\t\tCHANNELS 4 Xrotation Zrotation Yrotation"] + L[13:]), 13),
    "bad_offset": (lambda L: _join(L[:3] + ["\tOFFSET 0 x 0"] + L[4:]), 4),
    "bad_frames": (lambda L: _join(L[:21] + ["Frames: two"] + L[22:]), 22),
    "bad_frame_time": (lambda L: _join(L[:22] + ["Frame Time: 0"] + L[23:]), 23),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_malformed_bvh_names_file_and_line(case):
    make, line = BAD_CASES[case]
    text = make(_lines(SMALL))
    with pytest.raises(MocapFormatError) as err:
        read_bvh("bad.bvh", text=text)
    assert err.value.path == "bad.bvh"
    assert "bad.bvh" in str(err.value)
    if line is not None:
        assert err.value.line == line, str(err.value)
