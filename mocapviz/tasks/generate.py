"""Autoregressive motion synthesis with CCNet (paper §3.1, §4.2).

Seed frames are fed through the network (teacher forcing), then each new frame is the mean of
the predicted Gaussian (or a sample from it) with the predicted contact labels, fed back as the
next input. The trajectory control c^d comes from one of:

- ``traj``: an array of raw c^d per frame (e.g. taken from a clip; repeated cyclically);
- ``path``: a user path of world ground points (X, Z) per frame; c^d is recomputed every frame
  from the character's integrated root and heading, so the character steers onto the path;
- neither: the network's own predicted c^d (free-running, the paper's interactive fallback).

The output frame vectors turn back into poses with :func:`features_to_motion` (exp maps through
FK, integrated root path) and, unless switched off, contact-triggered two-bone leg IK.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from mocapviz.features.ccnet import FPS, TRAJ_STEPS, FeatureLayout, Normaliser, _yaw, features_to_motion
from mocapviz.ik import remove_foot_sliding
from mocapviz.models.ccnet import CCNet, CCNetStepper
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton


@dataclass
class Generated:
    x: np.ndarray            # (B, T, n_x) raw frame vectors, seed frames first
    n_seed: int

    def motion(self, i: int, skeleton: Skeleton, start_root=(0.0, 0.0, 0.0), start_heading: float = 0.0,
               ik: bool = True, include_seed: bool = True, name: str = "generated") -> Motion:
        x = self.x[i] if include_seed else self.x[i, self.n_seed:]
        m = features_to_motion(x, skeleton, start_root, start_heading, FPS, name=name)
        return remove_foot_sliding(m, m.meta["contacts"]) if ik else m


def path_controls(path_xz: np.ndarray, n: int, root_xz: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """c^d (B, 12) at frame n: path points n+10..n+60 relative to the root, in its heading frame."""
    idx = np.minimum(n + np.asarray(TRAJ_STEPS), path_xz.shape[1] - 1)
    d = path_xz[:, idx] - root_xz[:, None]                     # (B, 6, 2) world X, Z
    c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
    # R_y(theta)^T (dx, 0, dz): x' = c dx - s dz, z' = s dx + c dz
    local = np.stack([c * d[..., 0] - s * d[..., 1], s * d[..., 0] + c * d[..., 1]], axis=-1)
    return local.reshape(len(d), -1)


class Generator:
    """Batched autoregressive generation with the incremental stepper (or naive recompute)."""

    def __init__(self, model: CCNet, normaliser: Normaliser, batch: int = 1, sample: bool = False,
                 seed: int = 0):
        self.model = model.eval()
        self.norm = normaliser
        self.batch = batch
        self.sample = sample
        self.gen = torch.Generator().manual_seed(seed)
        self.cfg = model.cfg
        self.layout = FeatureLayout((self.cfg.n_x - 6) // 12, self.cfg.n_types)
        self.stepper = CCNetStepper(model, batch)

    def _next_input(self, raw_out: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        out = self.model.split_output(raw_out)
        mean = out["mean"]
        if self.sample:
            mean = mean + out["sigma"] * torch.randn(mean.shape, generator=self.gen)
        contact = (out["contact_logits"] > 0).to(mean.dtype)
        return torch.cat([mean, contact], -1), out["traj_mean"]

    @torch.inference_mode()
    def run(self, seed_x: np.ndarray, skel: np.ndarray, types: np.ndarray, n_frames: int,
            traj: np.ndarray | None = None, path: np.ndarray | None = None,
            seed_traj: np.ndarray | None = None, start_root=None, start_heading=None,
            progress: bool = False) -> Generated:
        """seed_x (B, S, n_x) raw seed frames; skel (B, n_skel) raw c^s; types (B, n_types) or
        (B, S + n_frames, n_types); traj (B, T_c, 12) raw c^d indexed by frame; path (B, T_p, 2)
        world X/Z per frame (needs start_root (B, 3), start_heading (B,) of frame -1 of the seed,
        as the clip's); seed_traj (B, S, 12) raw c^d of the seed frames (default: from ``traj``,
        ``path`` or zeros)."""
        from tqdm.auto import tqdm
        b, s = seed_x.shape[:2]
        total = s + n_frames
        norm = self.norm
        skel_n = torch.from_numpy(norm.norm_skel(skel))
        types = np.asarray(types, dtype=np.float32)
        per_frame_types = types.ndim == 3
        cur_type = types[:, 0] if per_frame_types else types
        self.stepper.reset()
        self.stepper.set_static(skel_n, torch.from_numpy(cur_type))
        xs = torch.zeros(b, total, self.cfg.n_x)
        xs[:, :s] = torch.from_numpy(norm.norm_x(seed_x))
        traj_n = None if traj is None else torch.from_numpy(norm.norm_traj(traj))
        root_b = self.layout.x_blocks["root"]
        if path is not None:
            root_xz = np.asarray(start_root, dtype=np.float64)[:, [0, 2]].copy()
            heading = np.asarray(start_heading, dtype=np.float64).copy()
        pred_traj = None
        for t in tqdm(range(total - 1), desc="generate", disable=not progress):
            if per_frame_types and t + 1 < total and not np.array_equal(types[:, t + 1], cur_type):
                cur_type = types[:, t + 1]
                self.stepper.set_static(skel_n, torch.from_numpy(cur_type))
            x_t = xs[:, t]
            if path is not None:  # integrate the root of frame t (raw units) for c^d_{t+1}
                r = x_t[:, root_b].numpy() * norm.x_std[root_b] + norm.x_mean[root_b]
                c, sn = np.cos(heading), np.sin(heading)
                root_xz += np.stack([c * r[:, 0] + sn * r[:, 1], -sn * r[:, 0] + c * r[:, 1]], 1) / FPS
                heading += r[:, 2] / FPS
            if t + 1 < s and seed_traj is not None:
                c_next = torch.from_numpy(norm.norm_traj(seed_traj[:, t + 1]))
            elif traj_n is not None:
                c_next = traj_n[:, (t + 1) % traj_n.shape[1]]
            elif path is not None:
                c_next = torch.from_numpy(norm.norm_traj(path_controls(path, t + 1, root_xz, heading)))
            elif pred_traj is not None:
                c_next = pred_traj
            else:
                c_next = torch.zeros(b, self.cfg.n_traj) if seed_traj is None else \
                    torch.from_numpy(norm.norm_traj(seed_traj[:, min(t + 1, s - 1)]))
            raw = self.stepper.step(x_t, c_next)
            nxt, pred_traj = self._next_input(raw)
            if t + 1 >= s:
                xs[:, t + 1] = nxt
        return Generated(norm.denorm_x(xs.numpy()), s)


@torch.inference_mode()
def naive_step_outputs(model: CCNet, x: torch.Tensor, skel, traj, types, window: int) -> torch.Tensor:
    """Reference: the last output for a (B, T) input, recomputing the last ``window`` frames."""
    out = model(x[:, -window:], skel, traj[:, -window:], types)
    return torch.cat([out["mean"], -torch.log(out["sigma"]), out["contact_logits"], out["traj_mean"]], -1)[:, -1]


def clip_types(type_index: int, n_types: int, batch: int = 1) -> np.ndarray:
    t = np.zeros((batch, n_types), dtype=np.float32)
    t[:, type_index] = 1.0
    return t


def straight_path(n: int, speed: float, start_xz=(0.0, 0.0), heading: float = 0.0) -> np.ndarray:
    """(n, 2) world X/Z of a straight line at ``speed`` m/s from ``start_xz`` along ``heading``."""
    d = np.array([np.sin(heading), np.cos(heading)])
    return np.asarray(start_xz)[None] + (np.arange(n) / FPS * speed)[:, None] * d[None]


def circle_path(n: int, speed: float, radius: float, start_xz=(0.0, 0.0), heading: float = 0.0) -> np.ndarray:
    """(n, 2) a circle of ``radius`` turning left, walked at ``speed`` m/s from ``start_xz``."""
    ang = np.arange(n) / FPS * speed / radius
    local = np.stack([radius * (1 - np.cos(ang)), radius * np.sin(ang)], axis=1)  # x right?, z forward
    rot = _yaw(np.array(heading))
    world = local[:, 0:1] * rot[[0, 2], 0][None] + local[:, 1:2] * rot[[0, 2], 2][None]
    return np.asarray(start_xz)[None] + world
