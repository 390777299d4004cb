"""GradNorm (Chen et al., ICML 2018): adaptive weights that make several losses fall at similar rates.

The 4D motion paper (§3.3) weights its partial reconstruction losses this way ([42]) but gives
no asymmetry; what we do, per training step, with task losses L_i and weights w_i:

- each task enters as its loss over its first value, scaled by the mean first value:
  Lhat_i = L_i S / L_i(0), S = mean_j L_j(0) (L_i(0): the losses of the first step after
  :meth:`GradNorm.reset`; see "Why the losses are normalised" below);
- G_i = w_i ||grad_W Lhat_i||, the norm of the weighted gradient at ``W``, the last layer whose
  weights every task's output depends on (for the CVAE: the decoder's last hidden layer);
- r_i = (L_i / L_i(0)) / mean_j(L_j / L_j(0)), the relative inverse training rate;
- target_i = mean_j(G_j) r_i^alpha (detached: a constant), L_grad = sum_i |G_i - target_i|; one
  Adam step on L_grad of the weights' logarithms, then the weights are renormalised to sum to the
  number of tasks (see "Why the step is on log-weights" below).

The network's gradient is sum_i w_i grad Lhat_i with the weights of this step (before their
update). Each task's gradient is taken once at the network's output and serves both the norms and
the network's step, so GradNorm costs no extra backward pass through the mesh or the encoder.

**Why the losses are normalised.** Chen et al. weight the raw losses. Ours are in different
units: phase 2's spatial loss (m^2 summed over 13,000 vertices and 100 frames, ~1e4) and its time
loss (~0.02), whose gradient norms at W started at 53,454 and 1.0. GradNorm on raw losses balances
the G_i by weights ~5e4 apart: with the renormalisation the spatial weight went to ~1e-5, far
below one Adam step of the weights (0.025), so it bounced between the floor and 0.025 from step to
step (logged means 1.4e-4 to 4e-4 against ~2), the network's gradient changed scale by orders of
magnitude between steps, and phase 2 moved the mean error by 0.2 %. Dividing each loss by its
first value removes the units (the ratios r_i, and hence the targets, are unchanged by it), so
the weights start balanced on losses of equal size, stay of order 1 and within a learning rate's
reach; the common factor S keeps the total at the first step equal to the plain sum of the
losses, the scale the paper's fixed KL weight (0.01) is relative to. ``normalise=False`` is
Chen et al.'s raw-loss GradNorm.

**alpha = 0.5** (``DEFAULT_ALPHA``): alpha sets how hard slow tasks are pulled back to the common
rate (alpha = 0 only equalises gradient norms); at balance w_i is proportional to r_i^alpha / ||grad
Lhat_i||, so the weights end about (r_slow / r_fast)^alpha apart. Chen et al. use 1.5 on NYUv2's
regression tasks and 0.12 when tasks are near-identical; the 4D paper gives none. Ours differ a
lot -- the 100 time stamps of a cycle are almost a straight line and fall 8x faster than the
126 x 100 rotation numbers -- and at 1.5 phase 1's weights drifted 33x apart. We chose alpha on
the validation cycles (``python -m data_prep train-cvae --alpha-sweep``, 80-epoch phase-1 runs,
``results/cvae4d_alpha_sweep.csv``): 0.5 / 1.0 / 1.5 gave 54.6 / 55.4 / 59.5 mm mean vertex
error, with weights at most 8.8x / 15x / 41x apart, with the additive step described below.
Redone with the step on log-weights: 57.6 / 56.9 / 55.9 mm, at most 6.6x / 9.2x / 31x apart in
80 epochs; the same runs on a rebuild of the data (chi equal to 7e-6) gave 53.6 / 56.2 / 58.2 mm and
5.2x / 9.0x / 19x, so the scores do not rank the alphas beyond an 80-epoch run's noise. Both phases trained in full at 1.0 (700 + 30 epochs, two seeds) showed that 80 epochs
hide the drift: phase 1's weights passed 10x apart at epoch 110 and reached 25.7x / 25.1x, while
0.5's full runs stayed within 7.3x / 6.8x (phase 1, two seeds) and 7.8x / 8.4x (phase 2). The
sweep therefore takes the best alpha whose weights stay within 10x in the short run and in every
full-length run at that alpha: 0.5.

**Why the step is on log-weights.** Chen et al. step the weights themselves. Adam's step is about
``lr`` whatever the gradient's size, so an additive step moves a weight of 0.3 by 8 % and one of
2.2 by 1 %: a run of same-signed steps (a loss spike, a few noisy batches) takes the small weight
to its floor within a dozen steps, and our 700-epoch phase 1 spent 9 % of its epochs with the
weights more than 10x apart at some step (up to 685x, the time weight at the floor of 1e-3 x 3).
Stepping log w_i moves every weight by the same fraction (about ``lr``) per step, the balance
point is unchanged (L_grad and its minimum are the same; only the parameterisation differs), and
no floor is needed (a weight cannot reach 0). ``tests/test_gradnorm.py`` checks on toys with
losses 1x and 1000x that the weights balance both the weighted gradients and the rates, and on a
noisy mini-batch toy with a loss spike that the additive step leaves 10x where this one does not.
"""

from __future__ import annotations

import torch

DEFAULT_ALPHA = 0.5
DEFAULT_LR = 0.025  # Adam on the log-weights: about the fraction a weight moves per step
ADDITIVE_FLOOR = 1e-3  # Chen et al.'s additive step only: smallest weight, a fraction of the number of tasks


class GradNorm:
    """Adaptive weights of ``names`` (tasks) balanced at one shared layer (module docstring).
    ``history`` (with ``keep_history``): one dict per step (losses L_, weights used w_, G_, r_).
    ``additive=True``: Chen et al.'s step on the weights themselves (kept for the comparison in
    the tests and the docstring, with their floor of 1e-3 x the number of tasks)."""

    def __init__(self, names, alpha: float = DEFAULT_ALPHA, lr: float = DEFAULT_LR, normalise: bool = True,
                 keep_history: bool = True, additive: bool = False):
        self.alpha, self.lr, self.normalise, self.keep_history = alpha, lr, normalise, keep_history
        self.additive = additive
        self.reset(names)

    def reset(self, names) -> None:
        """New tasks (e.g. phase 2 replaces pose + translation by the mesh): weights back to 1,
        initial losses forgotten (taken from the next step)."""
        self.names = tuple(names)
        # the trained parameter: the weights (additive) or their logarithms
        self.param = (torch.ones if self.additive else torch.zeros)(len(self.names), requires_grad=True)
        self.optimizer = torch.optim.Adam([self.param], lr=self.lr)
        self.initial: torch.Tensor | None = None
        self.history: list[dict[str, float]] = []

    def _weights(self) -> torch.Tensor:
        """The weights, differentiable in :attr:`param`."""
        return self.param if self.additive else self.param.exp()

    @property
    def weights(self) -> torch.Tensor:
        return self._weights().detach()

    def set_weights(self, values) -> None:
        with torch.no_grad():
            v = torch.as_tensor(values, dtype=self.param.dtype)
            self.param.copy_(v if self.additive else v.log())

    def current(self) -> dict[str, float]:
        return {n: float(w) for n, w in zip(self.names, self.weights.detach())}

    def factors(self) -> torch.Tensor:
        """The fixed factor of each loss in the network's objective: S / L_i(0) (ones without
        ``normalise`` or before the first step)."""
        if not self.normalise or self.initial is None:
            return torch.ones(len(self.names))
        return self.initial.mean() / self.initial

    def step(self, losses, output: torch.Tensor, shared: torch.Tensor, extra=None) -> dict[str, float]:
        """One GradNorm step: backpropagates sum_i w_i Lhat_i (+ ``extra``) into the parameters'
        ``.grad`` (zero them before) and updates the weights.

        ``losses``: the task losses in the order of ``names``, each a function of ``output``
        (a tensor downstream of every trained parameter: the CVAE's chi_hat); ``shared``: the
        weight tensor W; ``extra``: a loss with a fixed weight (the KL term). Each task's
        gradient at ``output`` is taken once (through the mesh, for the spatial loss) and serves
        both its norm at W (a short backward from ``output`` to W) and the one backward of the
        weighted sum through the network. Returns the weights used (w_), the G_i (G_), the rates
        r_i (r_); with ``keep_history`` the same and the task losses (L_) are appended to ``history``."""
        losses = list(losses)
        values = torch.stack([loss.detach() for loss in losses])
        if self.initial is None:
            self.initial = values.clamp_min(1e-12)
        k = self.factors()
        at_output = [ki * torch.autograd.grad(loss, output, retain_graph=True)[0] for ki, loss in zip(k, losses)]
        norms = torch.stack([torch.autograd.grad(output, shared, grad_outputs=g, retain_graph=True)[0].norm()
                             for g in at_output])
        w = self.weights.clone()
        weighted_grad = sum(wi * g for wi, g in zip(w, at_output))
        if extra is None:
            torch.autograd.backward([output], [weighted_grad])
        else:
            torch.autograd.backward([output, extra], [weighted_grad, torch.ones_like(extra)])

        ratio = values / self.initial
        rate = ratio / ratio.mean()
        weighted = self._weights() * norms  # G_i, differentiable in the weights only
        target = (weighted.mean() * rate ** self.alpha).detach()
        l_grad = (weighted - target).abs().sum()
        self.optimizer.zero_grad()
        l_grad.backward()
        self.optimizer.step()
        with torch.no_grad():  # renormalise: sum of weights = number of tasks
            n = len(self.names)
            if self.additive:
                self.param.clamp_(min=ADDITIVE_FLOOR * n)
                self.param.mul_(n / self.param.sum())
            else:
                self.param.sub_(torch.logsumexp(self.param, 0) - torch.log(torch.tensor(float(n))))
        out = {f"w_{n}": float(x) for n, x in zip(self.names, w)}
        out.update({f"G_{n}": float(x) for n, x in zip(self.names, w * norms)})
        out.update({f"r_{n}": float(x) for n, x in zip(self.names, rate)})
        if self.keep_history:
            self.history.append({**{f"L_{n}": float(x) for n, x in zip(self.names, values)}, **out})
        return out
