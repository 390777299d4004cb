"""The 4D CVAE's latent motion space (4D motion paper Fig. 1 right, §4.5 and Fig. 6).

- :func:`latent_means`: the encoder's mean mu of each cycle (z = mu, no sampling);
- :func:`latent_pca`: their 2-D PCA (scikit-learn) and its explained variance ratios;
- :func:`neighbour_agreement`: how clustered the types are in the full latent space (the share
  of cycles whose nearest other cycle in mu has the same motion type);
- :func:`type_medoid`: a representative cycle of a motion type (closest to its type's mean mu),
  the start or target of an interpolation;
- :func:`interpolate`: (z, beta) moved linearly from one cycle to another and decoded;
- :func:`cycle_measurements`: what notebook 13 reads along such a path, from chi alone:
  the decoded duration (Phi: run <-> walk), the root displacement over the cycle in the ground
  plane (Gamma: walk-back <-> walk-forward; ``forward_m`` is signed, +Z is the first heading
  after canonicalisation, so walking back is negative) and the root's heading change over the
  cycle (Theta's root rotation: left turn <-> right turn; positive = counter-clockwise seen
  from above = a left turn, :mod:`mocapviz.heading`'s convention);
- :func:`is_monotonic` and :func:`smallest_step`: the checks on those measurements.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import torch
from sklearn.decomposition import PCA

from mocapviz.bodies.representation import IDENTITY_6D, PHI_SCALE, split_chi
from mocapviz.heading import rotation_heading, wrap_angle
from mocapviz.rotations import sixd_to_matrix


@torch.no_grad()
def latent_means(model, chi: np.ndarray, batch: int = 256) -> np.ndarray:
    """mu (B, latent) of cycles chi (B, N, C): the encoder's mean, no sampling."""
    out = [model.encode(torch.as_tensor(chi[i:i + batch]))[0] for i in range(0, len(chi), batch)]
    return torch.cat(out).numpy() if out else np.zeros((0, model.cfg.latent), np.float32)


def latent_pca(mu: np.ndarray, n_components: int = 2) -> tuple[np.ndarray, np.ndarray, PCA]:
    """(coordinates (B, n_components), explained variance ratio per component, the fitted PCA)."""
    pca = PCA(n_components=n_components, svd_solver="full").fit(mu)
    return pca.transform(mu), pca.explained_variance_ratio_, pca


def neighbour_agreement(mu: np.ndarray, labels) -> float:
    """Share of cycles whose nearest other cycle (Euclidean, in mu) carries the same label."""
    from sklearn.neighbors import NearestNeighbors

    labels = np.asarray(labels)
    _, nn = NearestNeighbors(n_neighbors=2).fit(mu).kneighbors(mu)
    other = np.where(nn[:, 0] == np.arange(len(mu)), nn[:, 1], nn[:, 0])  # skip the cycle itself
    return float(np.mean(labels[other] == labels))


def type_medoid(mu: np.ndarray, candidates: np.ndarray) -> int:
    """The index among ``candidates`` whose mu is closest (Euclidean) to their mean mu."""
    candidates = np.asarray(candidates)
    if len(candidates) == 0:
        raise ValueError("no candidate cycles")
    centre = mu[candidates].mean(0)
    return int(candidates[np.argmin(np.linalg.norm(mu[candidates] - centre, axis=1))])


@torch.no_grad()
def interpolate(model, z0, beta0, z1, beta1, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(alphas (S,), chi (S, N, C), beta (S, n_beta)): (z, beta) = (1 - a) start + a target,
    a from 0 to 1 in ``n_steps`` even steps, decoded by the model."""
    alphas = np.linspace(0.0, 1.0, n_steps)
    a = torch.as_tensor(alphas, dtype=torch.float32)[:, None]
    z = (1 - a) * torch.as_tensor(z0, dtype=torch.float32) + a * torch.as_tensor(z1, dtype=torch.float32)
    beta = (1 - a) * torch.as_tensor(beta0, dtype=torch.float32) + a * torch.as_tensor(beta1, dtype=torch.float32)
    return alphas, model.decode(z, beta).numpy(), beta.numpy()


def cycle_measurements(chi: np.ndarray, n_kept: int, gamma_scale) -> pd.DataFrame:
    """One row per cycle chi (B, N, C): ``duration_s`` (last minus first timestamp),
    ``forward_m`` and ``side_m`` (root displacement first -> last frame along +Z and +X, metres),
    ``step_m`` (its ground-plane length) and ``turn_deg`` (the root's heading change, wrapped to
    [-180, 180), positive = left)."""
    chi = np.asarray(chi, dtype=np.float64)
    theta, gamma, phi = split_chi(chi, n_kept)
    move = (gamma[:, -1] - gamma[:, 0]) * np.asarray(gamma_scale)
    root = sixd_to_matrix(theta[:, [0, -1], 0] + IDENTITY_6D)  # (B, 2, 3, 3): first and last frame
    heading = rotation_heading(root)
    return pd.DataFrame(dict(duration_s=(phi[:, -1] - phi[:, 0]) * PHI_SCALE, forward_m=move[:, 2],
                             side_m=move[:, 0], step_m=np.hypot(move[:, 0], move[:, 2]),
                             turn_deg=np.degrees(wrap_angle(heading[:, 1] - heading[:, 0]))))


def is_monotonic(values) -> bool:
    """True when ``values`` never rise or never fall (ties allowed)."""
    d = np.diff(np.asarray(values, dtype=np.float64))
    return bool(np.all(d >= 0) or np.all(d <= 0))


def smallest_step(path_steps, train_steps) -> dict:
    """The smallest step along a path and how many training cycles make a step at most that long:
    {index, step_m, n_train_at_most, n_train, train_min_m}."""
    path_steps, train_steps = np.asarray(path_steps), np.asarray(train_steps)
    k = int(np.argmin(path_steps))
    return dict(index=k, step_m=float(path_steps[k]), n_train_at_most=int((train_steps <= path_steps[k]).sum()),
                n_train=len(train_steps), train_min_m=float(train_steps.min()))
