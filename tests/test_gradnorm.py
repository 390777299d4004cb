"""GradNorm on a two-task toy where one loss is 100x the other: the weights balance the rates."""

from __future__ import annotations

import pytest
import torch

from mocapviz.training.gradnorm import GradNorm


def _train(use_gradnorm: bool, steps: int = 1000, lr: float = 2e-3):
    """A shared trunk and one linear head with a column per task (every parameter before the
    output, as in the CVAE); task "big" is 100 x an MSE, task "small" an MSE of another target.
    Plain SGD, so a task's pace follows its gradient. Returns (L/L(0) per task, GradNorm, info)."""
    g = torch.Generator().manual_seed(0)
    x = torch.randn(256, 8, generator=g)
    a, b = torch.randn(8, generator=g), torch.randn(8, generator=g)
    y_small, y_big = torch.sin(x @ a), torch.cos(x @ b)
    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(8, 64), torch.nn.ReLU(), torch.nn.Linear(64, 64), torch.nn.ReLU(),
                              torch.nn.Linear(64, 2))
    opt = torch.optim.SGD(net.parameters(), lr=lr)
    gn = GradNorm(["small", "big"])
    first, info = None, None
    for _ in range(steps):
        out = net(x)
        losses = [torch.nn.functional.mse_loss(out[:, 0], y_small),
                  100 * torch.nn.functional.mse_loss(out[:, 1], y_big)]
        first = first or [float(v.detach()) for v in losses]
        opt.zero_grad()
        if use_gradnorm:
            info = gn.step(losses, out, net[2].weight)
        else:
            sum(losses).backward()
        opt.step()
    rates = [float(v.detach()) / f0 for v, f0 in zip(losses, first)]
    return rates, gn, info


def test_fixed_weights_leave_the_small_task_behind():
    (small, big), _, _ = _train(False)
    assert small / big > 100  # the 100x loss falls to 0.3 % of its start, the small one stays near 90 %


def test_gradnorm_balances_rates_and_gradients():
    (small, big), gn, info = _train(True)
    assert 0.67 < small / big < 1.5  # similar proportions of their initial losses
    w = gn.current()
    assert w["small"] + w["big"] == pytest.approx(2.0, rel=1e-5)  # renormalised to the number of tasks
    assert w["small"] / w["big"] > 50  # about the 100x scale of the losses' gradients
    assert 0.5 < info["G_small"] / info["G_big"] < 2.0  # weighted gradient norms at the shared layer


def test_reset_restores_unit_weights():
    gn = GradNorm(["a", "b"])
    with torch.no_grad():
        gn.weights.copy_(torch.tensor([1.9, 0.1]))
    gn.initial = torch.ones(2)
    gn.reset(["spatial", "time"])
    assert gn.current() == {"spatial": 1.0, "time": 1.0} and gn.initial is None


def test_network_gradient_is_the_weighted_sum():
    p = torch.nn.Parameter(torch.tensor([1.0, 2.0]))
    out = 1.0 * p
    gn = GradNorm(["a", "b"])
    with torch.no_grad():
        gn.weights.copy_(torch.tensor([0.5, 1.5]))
    info = gn.step([(out ** 2).sum(), 3 * out.sum()], out, p, extra=p.sum())
    # 0.5 * d(sum p^2) + 1.5 * d(3 sum p) + d(sum p)
    torch.testing.assert_close(p.grad, 0.5 * torch.tensor([2.0, 4.0]) + 1.5 * 3 + 1.0)
    # G_i = w_i |dL_i/dp|: 0.5 |(2, 4)| and 1.5 |(3, 3)|
    assert info["G_a"] == pytest.approx(0.5 * 20 ** 0.5) and info["G_b"] == pytest.approx(1.5 * 18 ** 0.5)
