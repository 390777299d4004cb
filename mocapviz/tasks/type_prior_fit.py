"""Fitting a latent CCNet's type prior (:class:`mocapviz.models.type_prior.TypePrior`) on clips:
each type's aggregate posterior of z over its clips' knots, one Gaussian, and its usual phase pace."""

from __future__ import annotations

import numpy as np

from mocapviz.features.ccnet import FeatureLayout
from mocapviz.features.phase import pace_hz
from mocapviz.models.type_prior import TypePrior, moment_matched
from mocapviz.tasks.one_step import teacher_forced_clip


def knot_posteriors(model, norm, clip: dict) -> tuple[np.ndarray, np.ndarray]:
    """Posterior means and variances (J, L) of the knots of z over one raw clip (a dict as
    ``CCNetDataset.clip_arrays``), each frame predicted from the true frames before it."""
    out = teacher_forced_clip(model, norm, clip, posterior=True)
    return out["z_mean"], np.exp(out["z_logvar"])


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
