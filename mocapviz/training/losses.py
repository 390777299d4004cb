"""CCNet's training loss (paper §3.3, Eq. 6-10).

L = L_G + lambda1 L_s + lambda2 L_f + lambda3 L_d with lambda = (10, 2, 1):

- L_G (Eq. 7): Gaussian negative log-likelihood of the continuous part of x_{n+1} under the
  predicted diagonal Gaussian (sigma = exp(-s) clipped at >= 1e-4), summed over channels.
- L_d (Eq. 10): the same Gaussian NLL for the predicted trajectory control c^d. The paper folds
  it into L_G; with lambda3 = 1 keeping it as a separate term is the same sum, and lets us log it.
- L_s (Eq. 8): smoothness of the predicted means. Eq. 8 as printed sums the *signed* second
  differences mu_{n-2} + mu_n - 2 mu_{n-1}, which telescopes and can go negative (so it would be
  minimised by making the motion ever more convex, not smooth). We use the **squared** second
  difference, **averaged** over channels (and frames). Summed over our 304 channels with
  lambda1 = 10 it outweighs L_G so much that the network learns to output a constant mean (zero
  acceleration) and lets sigma absorb the error: the ReLU before the decoder dies and generation
  shuffles in place. Averaged, it smooths without that collapse.
- L_f (Eq. 9): binary cross-entropy of the two foot-contact labels (from logits).

Channels that are constant in the training data (the rotations and angular velocities of joints
without rotational freedom: 44 of 304 in dataset v3) are left out of L_G and L_s (``channels``).
Kept in, their sigma shrinks (median 0.002 in the first committed model, together -218 of its
NLL per frame: the reported NLL was mostly these free nats), any dependence of their mean on the
input costs err^2 / sigma^2, and the network switched off most skip units before the decoder's
ReLU (9 of 64 ever active). Left out, the units stay alive (29 of 32 in a quick run); alone this
does not make the mean follow the input frame.

L_G, L_d and L_f are summed over their channels and averaged over frames and batch ("per frame").
In the logs L_d is ``traj_nll`` (the NLL of the predicted trajectory control c^d).

:data:`LOSSES` maps a registered model name (:mod:`mocapviz.models.protocol`) to its training
loss ``fn(out, batch, model_cfg, lambdas) -> dict`` (the total under ``"loss"``): the trainer
looks the loss up by the model's name, so a new model adds its loss here, not to the trainer.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

LAMBDAS = (10.0, 2.0, 1.0)
_HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)


def gaussian_nll(target: torch.Tensor, mean: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
    """Element-wise -ln N(target | mean, sigma^2)."""
    return torch.log(sigma) + 0.5 * ((target - mean) / sigma) ** 2 + _HALF_LOG_2PI


def smoothness(mean: torch.Tensor, channels: torch.Tensor | None = None) -> torch.Tensor:
    """Squared second difference of the means along time (B, T, D), averaged over D (or over the
    channels where the (D,) bool ``channels`` is true)."""
    if channels is not None:
        mean = mean[..., channels]
    if mean.shape[1] < 3:
        return mean.new_zeros(())
    d2 = mean[:, 2:] + mean[:, :-2] - 2 * mean[:, 1:-1]
    return (d2 ** 2).mean()


def ccnet_loss(out: dict, target_x: torch.Tensor, target_traj: torch.Tensor, n_continuous: int,
               lambdas=LAMBDAS, channels: torch.Tensor | None = None,
               kl_weight: float = 1.0) -> dict[str, torch.Tensor]:
    """out: the model's dict; target_x (B, T, n_x) = x_{t+1}; target_traj (B, T, 12) = c^d_{t+2};
    the first ``n_continuous`` channels of x are Gaussian, the rest contact labels; ``channels``
    (n_continuous,) bool: the continuous channels that count in L_G and L_s (None: all)."""
    l1, l2, l3 = lambdas
    elem = gaussian_nll(target_x[..., :n_continuous], out["mean"], out["sigma"])
    if channels is not None:
        elem = elem[..., channels]
    nll = elem.sum(-1).mean()
    traj_nll = gaussian_nll(target_traj, out["traj_mean"], out["traj_sigma"]).sum(-1).mean()
    contact = F.binary_cross_entropy_with_logits(out["contact_logits"], target_x[..., n_continuous:],
                                                 reduction="none").sum(-1).mean()
    smooth = smoothness(out["mean"], channels)
    total = nll + l1 * smooth + l2 * contact + l3 * traj_nll
    parts = dict(nll=nll, smooth=smooth, contact=contact, traj_nll=traj_nll)
    if "z_mean" in out:  # a latent model (CCNetConfig.latent): the ELBO's KL(posterior || prior) per frame,
        # each z counted once (one per block of CCNetConfig.latent_hold frames)
        kl = gaussian_kl(out["z_mean"], out["z_logvar"], out["prior_mean"], out["prior_logvar"])
        parts["kl"] = kl.sum((-1, -2)).mean() / out["mean"].shape[-2]
        total = total + kl_weight * parts["kl"]
    return dict(loss=total, **parts)


def gaussian_kl(mean, logvar, prior_mean, prior_logvar) -> torch.Tensor:
    """Element-wise KL(N(mean, exp(logvar)) || N(prior_mean, exp(prior_logvar))) in nats."""
    return 0.5 * (prior_logvar - logvar + (torch.exp(logvar) + (mean - prior_mean) ** 2) / torch.exp(prior_logvar) - 1.0)


def ccnet_window_loss(out: dict, batch: dict, cfg, lambdas=LAMBDAS,
                      kl_weight: float = 1.0) -> dict[str, torch.Tensor]:
    """:func:`ccnet_loss` on a training batch of :class:`mocapviz.training.windows.WindowData`
    (its ``varying`` channels count in L_G and L_s)."""
    return ccnet_loss(out, batch["target_x"], batch["target_traj"], cfg.n_continuous, lambdas, batch.get("varying"),
                      kl_weight)


LOSSES = {"ccnet": ccnet_window_loss}
# The baselines (mocapviz.models.baseline) write CCNet's output layout: the same loss (CCNet's
# L_G is Fragkiadaki's Gaussian-mixture loss with one mode, so it is ERD's own loss too).
LOSSES.update({name: ccnet_window_loss for name in ("erd", "dae_lstm", "pfnn")})
