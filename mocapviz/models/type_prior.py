"""A latent CCNet's prior of z given the motion type, fitted after training: p(z | type).

A latent model (``CCNetConfig.latent``) is trained with the prior N(0, I) for z, but the
posterior of a motion type's clips does not sit around 0: z = 0 decodes an average of all types,
and the generated waving of ``ccnet_generate`` stepped its feet in place (foot jitter
18-25x the real waving's). The type prior is each type's aggregate posterior over the
training clips, as one Gaussian: the mean of the posterior means of its knots, and their covariance
plus the mean posterior variance (the moments of the mixture of the knots' posteriors). Fitting a
density to the aggregate posterior after training is ex-post density estimation (Ghosh et al.
2020, "From variational to deterministic autoencoders", §4); here it is one Gaussian per type.

It is fitted by :func:`mocapviz.tasks.type_prior_fit.fit_type_prior`. The prior lives beside its checkpoint in ``<stem>.type_prior.safetensors``;
:func:`mocapviz.training.checkpoint.load_checkpoint` attaches it as ``model.type_prior``, and the
generator's mean output then decodes the type's mean and its samples draw from the type's Gaussian.
It also keeps each type's usual phase pace, for seeds that show no step cycle of their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from safetensors.numpy import load_file, save_file

SUFFIX = ".type_prior.safetensors"


def sidecar_path(checkpoint) -> Path:
    """Where the type prior of the checkpoint ``checkpoint`` lives."""
    p = Path(checkpoint)
    return p.with_name(p.name.removesuffix(".safetensors") + SUFFIX)


def moment_matched(z_means: np.ndarray, z_vars: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean (L,) and covariance (L, L) of the equal mixture of N(m_i, diag(v_i)), from the
    posterior means ``z_means`` (N, L) and variances ``z_vars`` (N, L): mean(m) and
    Cov(m) + diag(mean(v)) (Cov with 1/N, the mixture's own)."""
    m = np.asarray(z_means, np.float64)
    return m.mean(0), np.atleast_2d(np.cov(m.T, bias=True)) + np.diag(np.asarray(z_vars, np.float64).mean(0))


@dataclass
class TypePrior:
    mean: np.ndarray    # (n_types, L)
    chol: np.ndarray    # (n_types, L, L) lower Cholesky factor of each type's covariance
    counts: np.ndarray  # (n_types,) knots fitted per type; a type with none keeps N(0, I)
    # (n_types,) a phase model's median phase pace (Hz) of each type's training clips, 0 where none:
    # the pace its phase turns at after a seed that shows no cycle (features.phase.paced_phase)
    phase_hz: np.ndarray | None = None

    def draw(self, type_index: np.ndarray, e: np.ndarray) -> np.ndarray:
        """z (B, L) of the types ``type_index`` (B,) from standard normal draws ``e`` (B, L)."""
        return self.mean[type_index] + np.einsum("bij,bj->bi", self.chol[type_index], e).astype(np.float32)

    def save(self, path) -> Path:
        arrays = {"mean": self.mean, "chol": self.chol, "counts": self.counts}
        if self.phase_hz is not None:
            arrays["phase_hz"] = self.phase_hz
        save_file(arrays, str(path))
        return Path(path)

    @classmethod
    def load(cls, path) -> "TypePrior":
        return cls(**load_file(str(path)))
