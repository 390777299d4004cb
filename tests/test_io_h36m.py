"""H3.6M exp-map reader: our FK against an independent row-vector FK on real frames."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.errors import MocapFormatError
from mocapviz.io.h36m import H36M_PARENTS, _H36M_OFFSETS_MM, read_h36m


def _expmap2rotmat(r):
    """Rodrigues, as in the prediction papers' code (without their float32 eps)."""
    theta = np.linalg.norm(r)
    if theta == 0:
        return np.eye(3)
    k = r / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * kx @ kx


def _fkl_row_vectors(frame99):
    """xyz_child = offset . R_parent + xyz_parent; R_child = expmap2rotmat(r) . R_parent.

    Root translation and rotation (values 0:6) zeroed, as the prediction protocol does.
    """
    angles = np.asarray(frame99, dtype=np.float64).copy()
    angles[:6] = 0
    xyz, rot = [], []
    for i in range(32):
        r = _expmap2rotmat(angles[3 + 3 * i: 6 + 3 * i])
        if H36M_PARENTS[i] == -1:
            xyz.append(_H36M_OFFSETS_MM[i].astype(float))
            rot.append(r)
        else:
            p = H36M_PARENTS[i]
            xyz.append(_H36M_OFFSETS_MM[i] @ rot[p] + xyz[p])
            rot.append(r @ rot[p])
    return np.array(xyz) / 1000.0


def test_fk_matches_row_vector_reference(h36m_files):
    for path in h36m_files[::6]:
        m = read_h36m(path)
        pos = m.positions()
        raw = m.meta["expmap"]
        for f in np.linspace(0, m.n_frames - 1, 5).astype(int):
            np.testing.assert_allclose(pos[f], _fkl_row_vectors(raw[f]), atol=1e-9, err_msg=f"{path} frame {f}")


def test_shape_fps_and_line_count(h36m_files):
    path = h36m_files[0]
    m = read_h36m(path)
    lines = [line for line in path.read_text().splitlines() if line.strip()]
    assert m.n_frames == len(lines) and m.fps == 50.0
    assert m.skeleton.n_joints == 32 and m.meta["expmap"].shape == (len(lines), 99)
    np.testing.assert_array_equal(m.meta["expmap"][3], [float(v) for v in lines[3].split(",")])


def test_wrong_count_and_bad_number_name_the_line(h36m_files):
    lines = h36m_files[0].read_text().splitlines()[:6]
    bad = lines[:2] + [lines[2] + ",0.5"] + lines[3:]
    with pytest.raises(MocapFormatError) as err:
        read_h36m("h.txt", text="\n".join(bad))
    assert err.value.line == 3 and "h.txt" in str(err.value)
    bad = lines[:4] + [lines[4].replace(",", ",x", 1)] + lines[5:]
    with pytest.raises(MocapFormatError) as err:
        read_h36m("h.txt", text="\n".join(bad))
    assert err.value.line == 5
    with pytest.raises(MocapFormatError):
        read_h36m("h.txt", text="")
