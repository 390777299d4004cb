"""Fitting (z, beta) of a 4D CVAE to observations: time interpolation of chi and the Adam loop."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mocapviz.bodies.representation import PHI_SCALE
from mocapviz.models.cvae4d import CVAE4D, CVAE4DConfig
from mocapviz.tasks.cvae4d_fit import FitConfig, fit_latent, fit_to_vertices, interpolate_chi, vertex_loss


def _chi(values, times_s):
    """chi (1, N, 2): one value channel and Phi."""
    return torch.tensor([[[v, t / PHI_SCALE] for v, t in zip(values, times_s)]], dtype=torch.float64)


def test_interpolate_chi_by_timestamps_by_hand():
    chi = _chi([0.0, 1.0, 5.0], [0.0, 0.1, 0.3])
    out = interpolate_chi(chi, torch.tensor([[0.05, 0.1, 0.2, 0.25, -1.0, 1.0]], dtype=torch.float64))
    # halfway 0 -> 1; on frame 1; halfway 1 -> 5; three quarters 1 -> 5; clamped before / after
    np.testing.assert_allclose(out[0, :, 0].numpy(), [0.5, 1.0, 3.0, 4.0, 0.0, 5.0], atol=1e-12)
    np.testing.assert_allclose(out[0, :4, 1].numpy() * PHI_SCALE, [0.05, 0.1, 0.2, 0.25], atol=1e-12)


def test_interpolate_chi_repairs_a_decreasing_timestamp():
    # the running maximum makes times 0, 0.2, 0.2, 0.4: a time of 0.3 lies between frames 2 and 3
    chi = _chi([0.0, 2.0, 7.0, 4.0], [0.0, 0.2, 0.1, 0.4])
    out = interpolate_chi(chi, torch.tensor([[0.3]], dtype=torch.float64))
    assert float(out[0, 0, 0]) == pytest.approx(5.5)


def test_interpolate_chi_gradients():
    chi = _chi([0.0, 1.0, 5.0], [0.0, 0.1, 0.3]).requires_grad_(True)
    times = torch.tensor([[0.05, 0.27]], dtype=torch.float64)
    assert torch.autograd.gradcheck(lambda c: interpolate_chi(c, times), (chi,))
    # moving frame 1's timestamp later makes the value read at 0.05 smaller: d/dt1 of t/t1 = -t/t1^2
    interpolate_chi(chi, times)[0, 0, 0].backward()
    assert float(chi.grad[0, 1, 1]) == pytest.approx(-0.05 / 0.1 ** 2 * PHI_SCALE, rel=1e-9)


def _model(seed=0):
    torch.manual_seed(seed)
    return CVAE4D(CVAE4DConfig(n_frames=6, n_chi=7, n_beta=2, latent=3, hidden=(16, 8))).eval()


class _PointMesher:
    """A stand-in for ChiMesher: two 'vertices' per frame, chi's first six numbers plus beta[0]."""

    def __call__(self, chi, beta):
        return chi[..., :6].reshape(chi.shape[:-1] + (2, 3)) + beta[:, None, None, :1]


def test_fit_latent_decreases_the_loss_and_leaves_the_model_alone():
    model = _model()
    weights = [p.detach().clone() for p in model.parameters()]
    target = model.decode(torch.tensor([[0.5, -1.0, 0.3], [-0.2, 0.4, 1.0]]), torch.full((2, 2), 0.5)).detach()

    def loss_fn(chi, beta):
        return (chi - target).pow(2).mean(dim=(1, 2))
    res = fit_latent(model, loss_fn, torch.zeros(2, 3), torch.full((2, 2), 0.5), FitConfig(steps=300, lr=0.05,
                                                                                           fit_beta=False))
    assert res.losses[-1] < 0.01 * res.losses[0]
    assert torch.all(res.final < 1e-3)
    assert all(torch.equal(a, b) for a, b in zip(weights, model.parameters()))
    assert torch.equal(res.beta, torch.full((2, 2), 0.5))  # fit_beta=False keeps beta


def test_fit_to_vertices_recovers_observed_frames_and_clamps_beta():
    model, mesher = _model(1), _PointMesher()
    z_true, beta_true = torch.tensor([[0.8, -0.5, 0.2]]), torch.tensor([[0.3, 0.6]])
    chi_true = model.decode(z_true, beta_true).detach()
    t_all = torch.cummax(chi_true[..., -1] * PHI_SCALE, -1).values
    times = t_all[:, :4]  # the first four decoded timestamps are the observations
    targets = mesher(interpolate_chi(chi_true, times), beta_true)
    cfg = FitConfig(steps=400, lr=0.03, beta_bounds=(0.0, 1.0))
    res = fit_to_vertices(model, mesher, targets, times, beta0=torch.tensor([[0.5, 0.5]]), cfg=cfg)
    start = vertex_loss(mesher, targets, times)(model.decode(torch.zeros(1, 3), torch.tensor([[0.5, 0.5]])),
                                                 torch.tensor([[0.5, 0.5]]))
    assert float(res.final[0]) < 0.01 * float(start[0].detach())
    assert torch.all((res.beta >= 0) & (res.beta <= 1))


def test_vertex_loss_masks_padding_frames():
    mesher = _PointMesher()
    chi = _model().decode(torch.zeros(1, 3), torch.zeros(1, 2)).detach()
    times = torch.tensor([[0.0, 0.0]])
    good = mesher(interpolate_chi(chi, times), torch.zeros(1, 2))
    bad = good.clone()
    bad[:, 1] += 1.0  # a padding frame far off: masked, it must not count
    loss = vertex_loss(mesher, bad, times, mask=torch.tensor([[True, False]]))(chi, torch.zeros(1, 2))
    assert float(loss[0]) == pytest.approx(0.0, abs=1e-12)
    unmasked = vertex_loss(mesher, bad, times)(chi, torch.zeros(1, 2))
    assert float(unmasked[0]) == pytest.approx(0.5 * 3.0, rel=1e-6)  # one of two frames off by (1, 1, 1)


def test_weights_frozen_restores_each_flag_also_on_error():
    from mocapviz.tasks.cvae4d_fit import weights_frozen
    net = torch.nn.Sequential(torch.nn.Linear(2, 2), torch.nn.Linear(2, 1))
    net[1].bias.requires_grad_(False)
    before = [p.requires_grad for p in net.parameters()]
    with pytest.raises(RuntimeError):
        with weights_frozen(net):
            assert not any(p.requires_grad for p in net.parameters())
            raise RuntimeError("mid-fit")
    assert [p.requires_grad for p in net.parameters()] == before == [True, True, True, False]
