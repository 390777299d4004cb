"""A latent CCNet's prior of z given the motion type, fitted after training: p(z | type).

A latent model (``CCNetConfig.latent``) is trained with the prior N(0, I) for z, but the
posterior of a motion type's clips does not sit around 0: z = 0 decodes an average of all types,
and the generated waving of ``ccnet_phase_lerp_scale_root`` stepped its feet in place (foot jitter
18-25x the real waving's; issue 9). The type prior is each type's aggregate posterior over the
training clips, as one Gaussian: the mean of the posterior means of its knots, and their covariance
plus the mean posterior variance (the moments of the mixture of the knots' posteriors). Fitting a
density to the aggregate posterior after training is ex-post density estimation (Ghosh et al.
2020, "From variational to deterministic autoencoders", §4); here it is one Gaussian per type.

The prior lives beside its checkpoint in ``<stem>.type_prior.safetensors``;
:func:`mocapviz.training.checkpoint.load_checkpoint` attaches it as ``model.type_prior``, and the
generator's mean output then decodes the type's mean and its samples draw from the type's Gaussian.
It also keeps each type's usual phase pace, for seeds that show no step cycle of their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from safetensors.numpy import load_file, save_file

from mocapviz.features.ccnet import FeatureLayout
from mocapviz.features.motion_types import one_hot
from mocapviz.features.phase import pace_hz, phase_input

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
    centred = m - m.mean(0)
    return m.mean(0), centred.T @ centred / len(m) + np.diag(np.asarray(z_vars, np.float64).mean(0))


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


def knot_posteriors(model, norm, clip: dict) -> tuple[np.ndarray, np.ndarray]:
    """Posterior means and variances (J, L) of the knots of z over one raw clip (a dict as
    ``CCNetDataset.clip_arrays``), each frame predicted from the true frames before it."""
    x = norm.norm_x(clip["x"])
    traj = norm.norm_traj(clip["traj"])
    if model.cfg.phase:
        traj = np.concatenate([traj, phase_input(clip["x"], FeatureLayout.of_model(model.cfg))], axis=1)
    f = lambda a: torch.as_tensor(np.asarray(a, np.float32))[None]  # noqa: E731
    model.eval()
    with torch.no_grad():
        out = model(x=f(x[:-1]), skel=f(norm.norm_skel(clip["skel"])), traj=f(traj[1:]),
                    types=f(one_hot([clip["type_index"]], model.cfg.n_types)[0]), target_x=f(x[1:]))
    return out["z_mean"][0].numpy(), out["z_logvar"][0].exp().numpy()


def fit_type_prior(model, norm, clips, progress: bool = False, total: int | None = None) -> TypePrior:
    """The :class:`TypePrior` of ``model`` from raw ``clips`` (an iterable of ``total`` clip
    dicts; the training split's: the posterior of clips the model has not fitted would say less)."""
    from tqdm.auto import tqdm

    cfg = model.cfg
    if not cfg.latent:
        raise ValueError("a type prior needs a model with a latent z (CCNetConfig.latent)")
    layout = FeatureLayout.of_model(cfg)
    means, variances, paces = {}, {}, {}
    for clip in tqdm(clips, desc="type prior", total=total, disable=not progress):
        m, v = knot_posteriors(model, norm, clip)
        t = int(clip["type_index"])
        means.setdefault(t, []).append(m)
        variances.setdefault(t, []).append(v)
        if cfg.phase:
            paces.setdefault(t, []).append(pace_hz(clip["x"], layout))
    mean = np.zeros((cfg.n_types, cfg.latent), np.float32)
    chol = np.tile(np.eye(cfg.latent, dtype=np.float32), (cfg.n_types, 1, 1))
    counts = np.zeros(cfg.n_types, np.int64)
    phase_hz = np.zeros(cfg.n_types, np.float32)
    for t in means:
        mu, cov = moment_matched(np.concatenate(means[t]), np.concatenate(variances[t]))
        mean[t], counts[t] = mu, sum(map(len, means[t]))
        if cfg.phase:
            phase_hz[t] = np.median(paces[t])
        # a tiny ridge: a rare type has fewer knots than z has dimensions
        chol[t] = np.linalg.cholesky(cov + 1e-6 * np.eye(cfg.latent))
    return TypePrior(mean, chol, counts, phase_hz if cfg.phase else None)
