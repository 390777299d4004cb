"""Fit a 4D CVAE's latent code and body shape (z, beta) to observations with Adam (4D motion
paper §5 prediction, §6 completion).

Both applications optimise the decoder's inputs, not its weights: chi_hat = decoder(z, beta) is
a whole time-stamped cycle, and a loss compares it (or its meshes) with what was observed.

- :func:`~mocapviz.features.chi_time.interpolate_chi` (re-exported here): chi_hat (B, N, C)
  read at given times (B, T) in seconds, linearly between the two decoded frames around each
  time by the decoded timestamps Phi; differentiable in chi_hat's values and in its
  timestamps (the observations' *times* are matched, not their frame indices: a decoded cycle
  may be shorter or longer than the observed one);
- :func:`fit_latent`: the general loop. ``loss_fn(chi_hat, beta) -> (B,)`` is any per-sequence
  loss (vertex L2 here, Chamfer or marker terms for completion); the B sequences of a batch
  are independent fits (their losses are summed, Adam's steps are per element);
- :func:`fit_to_vertices`: the loss of §5, the mean squared distance between observed vertices
  (B, T, V', 3) at times (B, T) and the decoded mesh read at those times (a ``mask`` (B, T)
  marks real observations when sequences have different counts).

Start: z = 0 (the prior's mean) and beta = the caller's guess (e.g. the training mean), unless
given. ``beta_bounds`` clamps beta after each step (anny's phenotypes live in [0, 1]).
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass

import torch

from mocapviz.features.chi_time import interpolate_chi  # noqa: F401 - re-exported: part of the fitting API


@dataclass(frozen=True)
class FitConfig:
    steps: int = 150
    lr: float = 0.1  # prediction on the quick build: 0.1 fits the observed 0.25 s to 49 mm in 150 steps, 0.05 to 57
    fit_beta: bool = True
    beta_bounds: tuple[float, float] | None = (0.0, 1.0)
    z_weight: float = 0.0  # weight of mean(z^2) added to each loss (0: the paper's plain data term)


@dataclass
class FitResult:
    z: torch.Tensor        # (B, L)
    beta: torch.Tensor     # (B, n_beta)
    chi: torch.Tensor      # (B, N, C), decoded from the final (z, beta)
    losses: list           # total loss per step (summed over the batch)
    final: torch.Tensor    # (B,) data loss of each sequence at the final (z, beta)
    seconds: float


@contextmanager
def weights_frozen(model):
    """No weight gradients inside (cheaper, and the weights stay as they are); each parameter's
    requires_grad comes back afterwards, also on an error. For fits of the decoder's inputs."""
    trainable = [p.requires_grad for p in model.parameters()]
    for p in model.parameters():
        p.requires_grad_(False)
    try:
        yield model
    finally:
        for p, flag in zip(model.parameters(), trainable):
            p.requires_grad_(flag)


def fit_latent(model, loss_fn, z0: torch.Tensor, beta0: torch.Tensor, cfg: FitConfig = FitConfig(),
               progress: bool = False) -> FitResult:
    """Adam on (z, beta) (beta fixed unless ``cfg.fit_beta``) minimising the summed per-sequence
    ``loss_fn(chi_hat (B, N, C), beta (B, n_beta)) -> (B,)``; the model's weights are not changed."""
    from tqdm.auto import tqdm

    t_start = time.perf_counter()
    z = z0.detach().clone().float().requires_grad_(True)
    beta = beta0.detach().clone().float().requires_grad_(cfg.fit_beta)
    opt = torch.optim.Adam([z, beta] if cfg.fit_beta else [z], lr=cfg.lr)
    losses = []
    with weights_frozen(model):
        for _ in tqdm(range(cfg.steps), desc="fit (z, beta)", disable=not progress, leave=False):
            opt.zero_grad()
            per_seq = loss_fn(model.decode(z, beta), beta)
            total = (per_seq + cfg.z_weight * z.pow(2).mean(-1)).sum()
            total.backward()
            opt.step()
            if cfg.fit_beta and cfg.beta_bounds is not None:
                with torch.no_grad():
                    beta.clamp_(*cfg.beta_bounds)
            losses.append(float(total.detach()))
    with torch.no_grad():
        chi = model.decode(z, beta)
        final = loss_fn(chi, beta)
    return FitResult(z.detach(), beta.detach(), chi, losses, final, time.perf_counter() - t_start)


def vertices_at(mesher, chi: torch.Tensor, beta: torch.Tensor, times: torch.Tensor) -> torch.Tensor:
    """Vertices (B, T, V', 3) of cycles chi (B, N, C) on bodies beta read at ``times`` (B, T)."""
    return mesher(interpolate_chi(chi, times), beta)


def vertex_loss(mesher, targets: torch.Tensor, times: torch.Tensor, mask: torch.Tensor | None = None):
    """The loss of §5 as a ``loss_fn`` for :func:`fit_latent`: per sequence, the squared distance
    between observed vertices ``targets`` (B, T, V', 3) and the decoded mesh at ``times`` (B, T),
    averaged over vertices and the observed frames (``mask`` (B, T): True where observed)."""
    targets = torch.as_tensor(targets, dtype=torch.float32)
    times = torch.as_tensor(times, dtype=torch.float32)
    mask = torch.ones(times.shape, dtype=torch.bool) if mask is None else torch.as_tensor(mask, dtype=torch.bool)
    weight = mask.float() / mask.float().sum(1, keepdim=True).clamp_min(1.0)

    def loss_fn(chi, beta):
        sq = (vertices_at(mesher, chi, beta, times) - targets).pow(2).sum(-1).mean(-1)  # (B, T)
        return (sq * weight).sum(1)
    return loss_fn


def fit_to_vertices(model, mesher, targets, times, beta0, mask=None, z0=None, cfg: FitConfig = FitConfig(),
                    progress: bool = False) -> FitResult:
    """(z, beta) whose decoded mesh matches observed vertices ``targets`` (B, T, V', 3) at ``times``
    (B, T) seconds (``mask`` (B, T): real observations), from ``z0`` (default 0) and ``beta0`` (B, n_beta)."""
    beta0 = torch.as_tensor(beta0, dtype=torch.float32)
    z0 = torch.zeros(beta0.shape[0], model.cfg.latent) if z0 is None else torch.as_tensor(z0, dtype=torch.float32)
    return fit_latent(model, vertex_loss(mesher, targets, times, mask), z0, beta0, cfg, progress)
