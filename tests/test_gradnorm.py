"""GradNorm on a two-task toy where one loss is 100x the other: the weights balance the rates."""

from __future__ import annotations

import pytest
import torch

from mocapviz.training.gradnorm import GradNorm, task_gradients


def _train(use_gradnorm: bool, steps: int = 1000, lr: float = 2e-3):
    """A shared trunk, two heads; task "big" is 100 x an MSE, task "small" an MSE of another target.
    Plain SGD, so a task's pace follows its gradient. Returns (L/L(0) per task, GradNorm)."""
    g = torch.Generator().manual_seed(0)
    x = torch.randn(256, 8, generator=g)
    a, b = torch.randn(8, generator=g), torch.randn(8, generator=g)
    y_small, y_big = torch.sin(x @ a)[:, None], torch.cos(x @ b)[:, None]
    torch.manual_seed(0)
    trunk = torch.nn.Sequential(torch.nn.Linear(8, 64), torch.nn.ReLU(), torch.nn.Linear(64, 64), torch.nn.ReLU())
    heads = torch.nn.Linear(64, 1), torch.nn.Linear(64, 1)
    params = [*trunk.parameters(), *heads[0].parameters(), *heads[1].parameters()]
    opt = torch.optim.SGD(params, lr=lr)
    gn = GradNorm(["small", "big"])
    first = None
    for _ in range(steps):
        f = trunk(x)
        losses = [torch.nn.functional.mse_loss(heads[0](f), y_small),
                  100 * torch.nn.functional.mse_loss(heads[1](f), y_big)]
        first = first or [float(v.detach()) for v in losses]
        opt.zero_grad()
        if use_gradnorm:
            info = gn.step(losses, params, trunk[2].weight)
        else:
            sum(losses).backward()
        opt.step()
    rates = [float(v.detach()) / f0 for v, f0 in zip(losses, first)]
    return rates, gn, (info if use_gradnorm else None)


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
    losses = [(p ** 2).sum(), 3 * p.sum()]
    gn = GradNorm(["a", "b"])
    with torch.no_grad():
        gn.weights.copy_(torch.tensor([0.5, 1.5]))
    grads = task_gradients(losses, [p])
    torch.testing.assert_close(grads[0][0], torch.tensor([2.0, 4.0]))
    gn.step([(p ** 2).sum(), 3 * p.sum()], [p], p, extra=p.sum())
    torch.testing.assert_close(p.grad, 0.5 * torch.tensor([2.0, 4.0]) + 1.5 * 3 + 1.0)
