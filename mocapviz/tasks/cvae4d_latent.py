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

Checks that can fail: a number for the latent space alone says little unless
something simpler is measured the same way.

- :func:`clustering_scores`: :func:`neighbour_agreement` of the motion types in the latent
  means, in raw chi (each cycle flattened) and in PCA codes of chi of the latent's size (PCA fit on
  the training cycles, :func:`pca_codes`), beside chance (:func:`chance_agreement`). The latent
  space is "clustered by type" in a sense that can fail only if it is compared with these: raw
  chi needs no training at all, PCA is the linear code of the same size.
- :func:`path_comparison`: the interpolation checks (monotonic duration, displacement and turn,
  the smallest step against the training steps) and how far the path's cycles lie from the
  training cycles (:func:`nearest_distance`, RMS over chi's numbers), for the latent path and for
  baselines between the same two cycles: linear interpolation in raw chi, linear interpolation
  of their PCA codes (decoded by the PCA), and a random walk in the latent space from the start
  with the latent path's number and length of steps. A check that the raw line passes as well
  says nothing about the latent space; one the random walk passes says nothing at all.
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


# ---------------------------------------------------------------------------------- baselines
def chance_agreement(labels) -> float:
    """The neighbour agreement of labels drawn at random by their shares: sum of squared shares."""
    _, counts = np.unique(np.asarray(labels), return_counts=True)
    share = counts / counts.sum()
    return float((share ** 2).sum())


def pca_codes(chi: np.ndarray, train_idx, n_components: int) -> tuple[np.ndarray, PCA]:
    """(codes (B, n_components) of every cycle of chi (B, N, C), the PCA): PCA of the flattened
    cycles fitted on the training cycles ``train_idx`` only (at most their count - 1 components)."""
    flat = np.asarray(chi, dtype=np.float64).reshape(len(chi), -1)
    train_idx = np.asarray(train_idx)
    n = min(int(n_components), len(train_idx) - 1, flat.shape[1])
    pca = PCA(n_components=n, svd_solver="full").fit(flat[train_idx])
    return pca.transform(flat), pca


def clustering_scores(mu: np.ndarray, chi: np.ndarray, labels, train_idx) -> dict:
    """Neighbour agreement of ``labels`` in the latent means ``mu``, in raw chi (flattened) and in
    PCA codes of chi with mu's width (fitted on ``train_idx``), and by chance:
    {latent, raw_chi, pca, pca_components, chance}."""
    codes, pca = pca_codes(chi, train_idx, mu.shape[1])
    flat = np.asarray(chi, dtype=np.float64).reshape(len(chi), -1)
    return dict(latent=neighbour_agreement(mu, labels), raw_chi=neighbour_agreement(flat, labels),
                pca=neighbour_agreement(codes, labels), pca_components=int(pca.n_components_),
                chance=chance_agreement(labels))


def nearest_distance(chi_path: np.ndarray, chi_ref: np.ndarray) -> np.ndarray:
    """For each cycle of ``chi_path`` (S, N, C): the RMS difference (over chi's N x C numbers) to
    its nearest cycle in ``chi_ref`` (R, N, C)."""
    a = np.asarray(chi_path, dtype=np.float64).reshape(len(chi_path), -1)
    b = np.asarray(chi_ref, dtype=np.float64).reshape(len(chi_ref), -1)
    d2 = (a ** 2).sum(1)[:, None] - 2 * a @ b.T + (b ** 2).sum(1)[None]
    return np.sqrt(np.maximum(d2.min(1), 0) / a.shape[1])


def linear_path(x0, x1, n_steps: int) -> np.ndarray:
    """(n_steps, *x0.shape): (1 - a) x0 + a x1, a from 0 to 1 in even steps."""
    x0, x1 = np.asarray(x0, dtype=np.float64), np.asarray(x1, dtype=np.float64)
    a = np.linspace(0.0, 1.0, n_steps).reshape(-1, *[1] * x0.ndim)
    return (1 - a) * x0 + a * x1


def random_walk(z0, z1, n_steps: int, seed: int = 0) -> np.ndarray:
    """(n_steps, L): a walk from ``z0`` of n_steps - 1 steps in uniformly random directions, each
    as long as a step of the straight line z0 -> z1."""
    z0 = np.asarray(z0, dtype=np.float64)
    step = np.linalg.norm(np.asarray(z1, dtype=np.float64) - z0) / max(n_steps - 1, 1)
    d = np.random.default_rng(seed).standard_normal((n_steps - 1, len(z0)))
    d *= step / np.linalg.norm(d, axis=1, keepdims=True)
    return np.concatenate([z0[None], z0 + np.cumsum(d, 0)])


def path_checks(measures: pd.DataFrame, train_steps, chi_path: np.ndarray, chi_train: np.ndarray) -> dict:
    """The interpolation checks on one path's :func:`cycle_measurements` (and its chi): monotonic
    duration, forward displacement and turn; the smallest step and how many training steps are at
    most that long; the mean (over the path's inner cycles, ends excluded) RMS distance to the
    nearest training cycle (``chi_train``)."""
    s = smallest_step(measures["step_m"], train_steps)
    inner = chi_path[1:-1] if len(chi_path) > 2 else chi_path
    return dict(duration_monotonic=is_monotonic(measures["duration_s"]),
                forward_monotonic=is_monotonic(measures["forward_m"]),
                turn_monotonic=is_monotonic(measures["turn_deg"]),
                smallest_step_m=s["step_m"], n_train_at_most=s["n_train_at_most"],
                step_below_training=s["n_train_at_most"] == 0,
                nearest_train_rms=float(nearest_distance(inner, chi_train).mean()))


@torch.no_grad()
def path_comparison(model, chi: np.ndarray, beta: np.ndarray, mu: np.ndarray, i0: int, i1: int, train_idx,
                    n_steps: int, n_kept: int, gamma_scale, pca: PCA | None = None, seed: int = 0) -> pd.DataFrame:
    """One row per path from cycle ``i0`` to ``i1`` (:func:`path_checks` of each): ``latent`` (the
    model's :func:`interpolate`), ``raw_chi`` (linear in chi), ``pca`` (linear in the codes of
    ``pca``, a PCA of flattened chi as from :func:`pca_codes`; skipped if None) and
    ``random_walk`` (:func:`random_walk` in the latent space from mu[i0], beta moved as the latent
    path's, decoded). Training steps and the nearest cycles are those of ``train_idx``."""
    train_idx = np.asarray(train_idx)
    chi_train = np.asarray(chi)[train_idx]
    train_steps = cycle_measurements(chi_train, n_kept, gamma_scale)["step_m"]
    _, latent_chi, betas = interpolate(model, mu[i0], beta[i0], mu[i1], beta[i1], n_steps)
    paths = {"latent": latent_chi, "raw_chi": linear_path(chi[i0], chi[i1], n_steps)}
    if pca is not None:
        codes = pca.transform(np.asarray(chi, dtype=np.float64)[[i0, i1]].reshape(2, -1))
        paths["pca"] = pca.inverse_transform(linear_path(codes[0], codes[1], n_steps)).reshape(n_steps, *chi.shape[1:])
    walk = torch.as_tensor(random_walk(mu[i0], mu[i1], n_steps, seed), dtype=torch.float32)
    paths["random_walk"] = model.decode(walk, torch.as_tensor(betas, dtype=torch.float32)).numpy()
    rows = []
    for name, path in paths.items():
        m = cycle_measurements(path, n_kept, gamma_scale)
        rows.append(dict(path=name, **path_checks(m, train_steps, np.asarray(path), chi_train)))
    return pd.DataFrame(rows).set_index("path")
