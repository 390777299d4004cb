"""The 4D CVAE's latent space: means, PCA, medoids, interpolation and the path measurements."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mocapviz.bodies.representation import IDENTITY_6D, PHI_SCALE
from mocapviz.heading import yaw_matrix
from mocapviz.models.cvae4d import CVAE4D, CVAE4DConfig
from mocapviz.rotations import matrix_to_sixd
from mocapviz.tasks.cvae4d_latent import (
    cycle_measurements,
    interpolate,
    is_monotonic,
    latent_means,
    latent_pca,
    neighbour_agreement,
    smallest_step,
    type_medoid,
)


def test_latent_means_are_the_encoder_means_whatever_the_batch():
    torch.manual_seed(0)
    m = CVAE4D(CVAE4DConfig(n_frames=5, n_chi=10, n_beta=6, latent=4, hidden=(16, 8))).eval()
    chi = torch.randn(7, 5, 10)
    mu = latent_means(m, chi.numpy(), batch=3)
    assert mu.shape == (7, 4)
    np.testing.assert_allclose(mu, m(chi, torch.zeros(7, 6), sample=False)["mu"].detach().numpy(), atol=1e-6)


def test_latent_pca_of_a_cross():
    # x spread 1 (sum of squares 2), y spread 0.5 (0.5): ratios 0.8 and 0.2; z is constant
    mu = np.array([[1.0, 0, 3], [-1, 0, 3], [0, 0.5, 3], [0, -0.5, 3]])
    xy, ratio, _ = latent_pca(mu)
    np.testing.assert_allclose(ratio, [0.8, 0.2], atol=1e-9)
    np.testing.assert_allclose(np.abs(xy[:, 0]), [1, 1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(np.abs(xy[:, 1]), [0, 0, 0.5, 0.5], atol=1e-9)


def test_neighbour_agreement():
    mu = np.array([[0.0], [0.1], [5.0], [5.1], [9.0]])
    # nearest others: 1, 0, 3, 2, 3 -> labels a a b b a: agree, agree, agree, agree, not (b)
    assert neighbour_agreement(mu, list("aabba")) == pytest.approx(0.8)
    assert neighbour_agreement(mu, list("ababa")) == pytest.approx(0.0)


def test_type_medoid_is_closest_to_the_type_mean():
    mu = np.array([[0.0, 0], [1, 0], [10, 0], [2, 0]])
    assert type_medoid(mu, np.array([0, 1, 3])) == 1  # mean 1
    assert type_medoid(mu, np.array([1, 2, 3])) == 3  # mean 13/3: distances 3.33, 5.67, 2.33
    with pytest.raises(ValueError):
        type_medoid(mu, np.array([], int))


class _Concat:
    """Decodes (z, beta) to one frame holding both, to read what interpolate fed it."""

    @staticmethod
    def decode(z, beta):
        return torch.cat([z, beta], -1)[:, None, :]


def test_interpolate_is_linear_in_z_and_beta():
    alphas, chi, beta = interpolate(_Concat(), [0.0, 2.0], [1.0], [4.0, -2.0], [3.0], 5)
    np.testing.assert_allclose(alphas, [0, 0.25, 0.5, 0.75, 1])
    np.testing.assert_allclose(chi[:, 0], [[0, 2, 1], [1, 1, 1.5], [2, 0, 2], [3, -1, 2.5], [4, -2, 3]])
    np.testing.assert_allclose(beta[:, 0], [1, 1.5, 2, 2.5, 3])


def _cycle(yaw_first, yaw_last, root_last, phi, gamma_scale, n_kept=2):
    """chi (3, 6 n_kept + 4): root yaws at the first and last frame, other joints at rest, the
    root moving from 0 to ``root_last`` (metres), timestamps ``phi``."""
    chi = np.zeros((3, 6 * n_kept + 4))
    for f, yaw in ((0, yaw_first), (1, yaw_first), (2, yaw_last)):
        chi[f, :6] = matrix_to_sixd(yaw_matrix(np.radians(yaw))) - IDENTITY_6D
    chi[2, 6 * n_kept:6 * n_kept + 3] = np.asarray(root_last) / np.asarray(gamma_scale)
    chi[:, -1] = phi
    return chi


def test_cycle_measurements_by_hand():
    scale = (2.0, 1.0, 4.0)
    walk_back_left = _cycle(0, 30, (0.5, 0.1, -1.0), [0, 0.1, 0.3], scale)
    across_pi = _cycle(170, -170, (0.0, 0.0, 0.6), [0.05, 0.2, 0.45], scale)  # heading wraps: +20 deg
    m = cycle_measurements(np.stack([walk_back_left, across_pi]), 2, scale)
    np.testing.assert_allclose(m.duration_s, [0.3 * PHI_SCALE, 0.4 * PHI_SCALE], atol=1e-9)
    np.testing.assert_allclose(m.forward_m, [-1.0, 0.6], atol=1e-9)
    np.testing.assert_allclose(m.side_m, [0.5, 0.0], atol=1e-9)
    np.testing.assert_allclose(m.step_m, [np.sqrt(1.25), 0.6], atol=1e-9)
    np.testing.assert_allclose(m.turn_deg, [30.0, 20.0], atol=1e-6)
    right = cycle_measurements(_cycle(10, -25, (0, 0, 1), [0, 0.1, 0.2], scale)[None], 2, scale)
    np.testing.assert_allclose(right.turn_deg, [-35.0], atol=1e-6)


def test_monotonic_and_smallest_step():
    assert is_monotonic([1, 2, 2, 3]) and is_monotonic([3, 2, 1]) and not is_monotonic([1, 3, 2])
    s = smallest_step([0.5, 0.1, 0.3], [0.05, 0.2, 0.6, 0.1])
    assert s == dict(index=1, step_m=0.1, n_train_at_most=2, n_train=4, train_min_m=0.05)
    assert smallest_step([0.5, 0.3], [0.4, 0.6])["n_train_at_most"] == 0
