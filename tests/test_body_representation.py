"""chi = [Theta, Gamma, Phi]: normalisation invariants and the chi -> mesh -> chi round trip."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.bodies.anny_model import body_model
from mocapviz.bodies.representation import (DROPPED_JOINTS, N_FRAMES, chi_from_mesh, chi_joint_indices, decode,
                                            encode, mesh_chi, split_chi)
from mocapviz.heading import rotation_heading


@pytest.fixture(scope="session")
def body():
    return body_model()


@pytest.fixture(scope="session")
def real_cycle(body, data_dir):
    """The reference walk cycle of CMU 07_01 on subject 07's fitted anny body, 100 frames."""
    from data_prep.body4d_dataset import REFERENCE_CLIP, REFERENCE_FRAMES
    from data_prep.catalog import build_catalog, load_motion
    from mocapviz.bodies.retarget import retarget
    from mocapviz.bodies.shape_fit import fit_shapes
    from mocapviz.features.cycles import resample_uniform
    cat = build_catalog(data_dir)
    m = load_motion(cat[cat["clip"] == REFERENCE_CLIP].iloc[0])
    beta = fit_shapes(body, {"s": m.skeleton}, steps=40).beta[0]
    rot, root, times = resample_uniform(retarget(m, body.rest_skeleton(beta)), *REFERENCE_FRAMES, N_FRAMES)
    return beta, rot, root, times


GAMMA_SCALE = np.array([0.5, 0.2, 2.0])


def test_chi_layout_and_normalisation(body, real_cycle):
    beta, rot, root, times = real_cycle
    kept = chi_joint_indices(body.joint_names)
    assert len(kept) == body.n_joints - len(DROPPED_JOINTS) == 21
    chi = encode(rot, root, times, kept, GAMMA_SCALE)
    assert chi.shape == (N_FRAMES, 6 * 21 + 4) and chi.dtype == np.float32
    theta, gamma, phi = split_chi(chi, len(kept))
    np.testing.assert_array_equal(gamma[0], 0)
    assert phi[0] == 0 and phi[-1] == pytest.approx((261 - 134) / 120 / 3.0, rel=1e-6)
    assert np.all(np.diff(phi) > 0)
    assert np.abs(theta).max() < 2.01  # a 6-D rotation minus identity is bounded by 2
    assert gamma[-1, 2] > 0.4  # a forward walk goes along +Z after the heading is removed
    rot2, root2, t2 = decode(chi, kept, body.n_joints, GAMMA_SCALE)
    assert abs(rotation_heading(rot2[0, 0])) < 1e-5  # initial heading is the identity in the ground plane
    np.testing.assert_allclose(rot2[:, kept[1:]], rot[:, kept[1:]], atol=1e-5)  # non-root joints unchanged


def test_chi_mesh_chi_round_trip(body, real_cycle):
    beta, rot, root, times = real_cycle
    kept = chi_joint_indices(body.joint_names)
    chi = encode(rot, root, times, kept, GAMMA_SCALE)
    verts = mesh_chi(body, beta, chi, GAMMA_SCALE)
    assert verts.shape == (N_FRAMES, body.n_vertices, 3)
    chi2 = chi_from_mesh(body, beta, verts, times, GAMMA_SCALE)
    np.testing.assert_allclose(chi2, chi, atol=2e-4)
    verts2 = mesh_chi(body, beta, chi2, GAMMA_SCALE)
    assert float((verts2 - verts).norm(dim=-1).max()) < 1e-4  # metres


def test_sixd_pair_round_trips_real_rotations(real_cycle):
    """matrix_to_sixd keeps the first two columns; sixd_to_matrix rebuilds the third."""
    from mocapviz.rotations import matrix_to_sixd, sixd_to_matrix
    rot = real_cycle[1]  # (N, J, 3, 3) local rotations of a real cycle
    sixd = matrix_to_sixd(rot)
    np.testing.assert_array_equal(sixd[..., :3], rot[..., :, 0])
    np.testing.assert_array_equal(sixd[..., 3:], rot[..., :, 1])
    np.testing.assert_allclose(sixd_to_matrix(sixd), rot, atol=1e-9)
