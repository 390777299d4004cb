"""Test helpers (also used by benchmarks/bench_generation.py): the generator's kept step outputs
next to one full forward pass over the same generated sequence, for the incremental = full check."""

from __future__ import annotations

import numpy as np
import torch


def step_outputs(gen_raw: list[np.ndarray], cfg) -> tuple[np.ndarray, np.ndarray]:
    """Stack a generator's kept raw outputs into (mean, contact logits, c^d mean) (B, T-1, .),
    and the c^d (normalised) each step predicted (B, T-1, 12)."""
    raw = np.stack(gen_raw, 1)
    out = cfg.output_slices
    traj = raw[..., out["traj_mean"]]
    return np.concatenate([raw[..., out["mean"]], raw[..., out["contact_logits"]], traj], -1), traj


def controls_used(gen, seed_traj: np.ndarray, pred: np.ndarray, norm, cfg) -> np.ndarray:
    """(B, T-1, n_traj) the c^d a free-running generation fed at each step: the seed's own
    (normalised) for the seed, then the c^d each step predicted; a phase model's last two
    channels are the phase the generator fed (``gen.phase``)."""
    s = gen.n_seed
    if not cfg.phase:
        return np.concatenate([norm.norm_traj(seed_traj[:, 1:]), pred[:, s - 2:-1]], 1)
    plain = np.concatenate([norm.norm_traj(seed_traj[:, 1:]), pred[:, s - 2:-1, :-2]], 1)
    return np.concatenate([plain, gen.phase[:, 1:]], -1)


@torch.inference_mode()
def full_recompute_outputs(model, norm, gen, skel: np.ndarray, types: np.ndarray, traj_n: np.ndarray) -> np.ndarray:
    """(mean, contact logits, c^d mean) of one full forward pass over a generated sequence
    ``gen``: inputs x_0..x_{T-2} with the controls the generator used (traj_n (B, T-1, 12),
    normalised)."""
    x = torch.from_numpy(gen.x_norm[:, :-1])
    out = model(x, torch.from_numpy(norm.norm_skel(skel)), torch.from_numpy(np.asarray(traj_n, np.float32)),
                torch.from_numpy(np.asarray(types, np.float32)))
    return torch.cat([out["mean"], out["contact_logits"], out["traj_mean"]], -1).numpy()
