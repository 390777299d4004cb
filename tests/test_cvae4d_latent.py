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
    chance_agreement,
    clustering_scores,
    cycle_measurements,
    linear_path,
    nearest_distance,
    path_checks,
    path_comparison,
    pca_codes,
    random_walk,
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


# ---------------------------------------------------------------------- checks that can fail
def test_chance_agreement_is_the_sum_of_squared_shares():
    assert chance_agreement(list("aabbbb")) == pytest.approx((1 / 3) ** 2 + (2 / 3) ** 2)
    assert chance_agreement(["x"] * 4) == 1.0


def _clustered(n_per=10, seed=0):
    """chi (3 n_per, 4, 3) of three types, each a constant offset plus noise on the first number;
    a 'latent' mu that scrambles the types (random), another that separates them."""
    rng = np.random.default_rng(seed)
    labels = np.repeat(["a", "b", "c"], n_per)
    chi = rng.normal(0, 0.1, (3 * n_per, 4, 3))
    chi[:, 0, 0] += np.repeat([0.0, 5.0, 10.0], n_per)
    return chi, labels, rng


def test_clustering_scores_compare_the_latent_with_raw_chi_and_pca():
    chi, labels, rng = _clustered()
    train = np.arange(0, 30, 2)
    good = clustering_scores(chi[:, 0, :1] + 0.0, chi, labels, train)
    assert good["raw_chi"] == good["pca"] == good["latent"] == 1.0 and good["pca_components"] == 1
    bad = clustering_scores(rng.normal(size=(30, 2)), chi, labels, train)
    assert bad["latent"] < 0.7 and bad["raw_chi"] == bad["pca"] == 1.0  # a latent worse than both fails
    assert bad["chance"] == pytest.approx(1 / 3) and bad["pca_components"] == 2


def test_pca_codes_fit_on_training_cycles_only():
    chi, _, _ = _clustered()
    train = np.arange(10)  # type a only: its spread is the noise, type b and c lie far off the fit
    codes, pca = pca_codes(chi, train, 3)
    assert codes.shape == (30, 3) and pca.n_components_ == 3
    np.testing.assert_allclose(pca.mean_, chi[train].reshape(10, -1).mean(0))
    assert pca_codes(chi, train[:3], 64)[1].n_components_ == 2  # at most n_train - 1 components


def test_nearest_distance_linear_path_and_random_walk():
    ref = np.zeros((2, 2, 2))
    ref[1] += 1.0
    np.testing.assert_allclose(nearest_distance(np.stack([np.full((2, 2), 0.25), np.full((2, 2), 0.75)]), ref), [0.25, 0.25])
    path = linear_path(np.zeros(3), np.array([2.0, 4.0, 6.0]), 3)
    np.testing.assert_allclose(path, [[0, 0, 0], [1, 2, 3], [2, 4, 6]])
    walk = random_walk(np.zeros(4), np.full(4, 2.0), 5, seed=1)  # straight line 4 long, steps of 1
    assert walk.shape == (5, 4) and np.all(walk[0] == 0)
    np.testing.assert_allclose(np.linalg.norm(np.diff(walk, axis=0), axis=1), 1.0)
    assert not np.allclose(walk[-1], 2.0)


def _walk(forward_m, seconds=1.0, n_kept=1):
    """chi (2, 6 n_kept + 4): the root moving ``forward_m`` along +Z in ``seconds``, no turn."""
    chi = np.zeros((2, 6 * n_kept + 4))
    chi[1, 6 * n_kept + 2] = forward_m
    chi[1, -1] = seconds / PHI_SCALE
    return chi


def test_path_checks_raw_line_from_back_to_forward_passes_a_small_step():
    """The line in raw chi from a walk back to a walk forward crosses a zero step: the
    "smaller than any training step" check passes without any model."""
    start, target = _walk(-1.0), _walk(1.0)
    path = linear_path(start, target, 5)
    train = np.stack([_walk(0.5), _walk(-0.8), _walk(1.2)])
    m = cycle_measurements(path, 1, (1.0, 1.0, 1.0))
    c = path_checks(m, cycle_measurements(train, 1, (1.0, 1.0, 1.0))["step_m"], path, train)
    assert c["step_below_training"] and c["smallest_step_m"] == pytest.approx(0.0, abs=1e-9)
    assert c["forward_monotonic"] and c["duration_monotonic"] and c["turn_monotonic"]
    # inner cycles at -0.5, 0, 0.5 m: nearest training -0.8 (0.3 off), 0.5 (0.5), 0.5 (0); one number of 20 differs
    assert c["nearest_train_rms"] == pytest.approx(np.mean([0.3, 0.5, 0.0]) / np.sqrt(20), rel=1e-6)


class _Linear:
    """A 'decoder' chi = [z as the forward displacement of a 1-joint cycle], beta ignored."""

    @staticmethod
    def decode(z, beta):
        out = torch.zeros(len(z), 2, 10)
        out[:, 1, 8] = z[:, 0]
        out[:, 1, -1] = 1.0 / PHI_SCALE
        return out


def test_path_comparison_rows_and_a_baseline_that_fails():
    chi = np.stack([_walk(-1.0), _walk(1.0), _walk(0.5), _walk(-0.8)]).astype(np.float32)
    mu = np.array([[-1.0], [1.0], [0.5], [-0.8]])
    beta = np.zeros((4, 6))
    _, pca = pca_codes(chi, [0, 1, 2, 3], 1)
    t = path_comparison(_Linear(), chi, beta, mu, 0, 1, [1, 2, 3], 5, 1, (1.0, 1.0, 1.0), pca, seed=0)
    assert list(t.index) == ["latent", "raw_chi", "pca", "random_walk"]
    assert t.loc["latent", "step_below_training"] and t.loc["raw_chi", "step_below_training"]
    assert t.loc["pca", "step_below_training"]
    # the random walk (steps of 0.5 in 1-D, from -1) goes nowhere near +1 monotonically by chance
    walk = random_walk(mu[0], mu[1], 5, seed=0)[:, 0]
    assert t.loc["random_walk", "forward_monotonic"] == is_monotonic(walk)
    assert t.loc["random_walk", "smallest_step_m"] == pytest.approx(np.abs(walk).min(), abs=1e-6)
