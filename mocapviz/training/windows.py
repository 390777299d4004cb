"""Training windows of a CCNet dataset: normalised arrays and a sampler of (clip, start) windows."""

from __future__ import annotations

import numpy as np
import torch

from mocapviz.features.motion_types import one_hot
from mocapviz.features.phase import clip_phases

VAL_STRIDE = 10


class WindowData:
    """Normalised arrays of a CCNet dataset and a sampler of training windows.

    ``ds`` is a :class:`mocapviz.datasets.ccnet.CCNetDataset` (anything with the same fields).
    Every model on the CCNet features (CCNet, and the recurrent baselines) trains on these
    batches; a batch's keys are the models' ``input_names`` plus the targets.
    """

    # inputs an ablation can hide (TrainConfig.hidden_inputs): "rotations" the joint rotations and
    # angular velocities of x_t (paper §4.8.2 "w/o ROT"), "skeleton" c^s ("w/o SK")
    HIDEABLE = ("rotations", "skeleton")

    def __init__(self, ds, window: int, normaliser=None, phase: bool = False, hidden_inputs=()):
        unknown = set(hidden_inputs) - set(self.HIDEABLE)
        if unknown:
            raise ValueError(f"cannot hide {sorted(unknown)}: choose from {self.HIDEABLE}")
        norm = normaliser or ds.normaliser
        self.window = window
        self.layout = ds.layout
        self.x = torch.from_numpy(norm.norm_x(ds.x))
        # a hidden input is its training mean (0 normalised) in every window the model reads, so the
        # network cannot see it; the targets keep it (the loss stays the same sum, comparable)
        self._x_shown = torch.ones(self.x.shape[1])
        if "rotations" in hidden_inputs:
            b = self.layout.x_blocks
            self._x_shown[b["rot"]] = self._x_shown[b["angvel"]] = 0.0
        self._skel_shown = 0.0 if "skeleton" in hidden_inputs else 1.0
        self.hidden_inputs = tuple(hidden_inputs)
        traj = norm.norm_traj(ds.traj)
        if phase:  # c^d gains the local phase (sin, cos), unnormalised (CCNetConfig.phase)
            traj = np.concatenate([traj, clip_phases(ds)], axis=1)
        self.traj = torch.from_numpy(traj)
        self.skel = torch.from_numpy(norm.norm_skel(ds.skel))
        self.varying = torch.from_numpy(~norm.constant_channels())  # the channels counted in L_G and L_s
        self.types = torch.from_numpy(one_hot(ds.clips.type_index.values, self.layout.n_types))
        self.clip_start = ds.clips.start.values
        self.train = ds.window_starts("train", window)
        self.test = ds.window_starts("test", window, stride=window)
        # validation (the held-out actor mm and 10 % of Bandai's takes): a window every
        # VAL_STRIDE frames, so every frame counts at window / VAL_STRIDE context lengths. Stride 1
        # gave ~30,000 windows of 120 frames once Bandai joined: an evaluation of the paper-width
        # network then cost as much as ~100 training steps on a GPU.
        self.val = ds.window_starts("val", window, stride=VAL_STRIDE)
        self.n_train_frames = int(sum(r.stop - r.start for r in ds.clips.itertuples() if r.split == "train"))
        # per channel, the mask of what grows with the body and mean / std (see ``scaled``)
        n, n_traj = len(norm.x_mean), self.layout.n_traj
        grows = self.layout.length_channels
        self._x_grow = torch.from_numpy(grows.astype(np.float32))
        self._x_k = torch.zeros(len(grows))
        self._x_k[:n] = torch.from_numpy(norm.x_mean / norm.x_std)
        self._traj_grow = torch.zeros(self.traj.shape[1])
        self._traj_grow[:n_traj] = 1.0        # the ground positions, not the phase columns after them
        self._traj_k = torch.zeros(self.traj.shape[1])
        self._traj_k[:n_traj] = torch.from_numpy(norm.traj_mean / norm.traj_std)
        self._skel_k = torch.from_numpy(norm.skel_mean / norm.skel_std)

    def to(self, device) -> "WindowData":
        """Move the arrays to ``device`` (a GPU keeps the whole dataset: 0.5 GB for dataset v4),
        so a batch is a gather there, not a copy from host memory. Returns self."""
        for name in ("x", "traj", "skel", "varying", "types", "_x_grow", "_x_k", "_traj_grow", "_traj_k", "_skel_k",
                     "_x_shown"):
            setattr(self, name, getattr(self, name).to(device))
        return self

    def draw_train(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` training windows drawn uniformly with replacement."""
        return self.train[rng.integers(len(self.train), size=n)]

    def scaled(self, b: dict, s) -> dict[str, torch.Tensor]:
        """The batch ``b`` with each window's body and motion ``s`` (B,) times as large: c^s, the
        ground positions of c^d and x's lengths and velocities (m, m/s) times s; rotations, rates,
        contacts and phase unchanged. Exact, not an approximation: FK of the same rotations on
        offsets s times as long is s times the positions. Why: 90 % of dataset v4's training frames
        are one Bandai body, and a network that has seen a body at one size only reads c^s to the
        hundredth (generate_bvh.seen_scale). On normalised values v = (u - mean) / std, u -> s u is
        v -> v + (s - 1)(v + mean / std) on the channels that grow."""
        s = torch.as_tensor(np.asarray(s, np.float32), device=self.x.device)
        out = dict(b)
        for keys, grow, k in ((("x", "target_x"), self._x_grow, self._x_k),
                              (("traj", "target_traj"), self._traj_grow, self._traj_k),
                              (("skel",), 1.0, self._skel_k)):
            for key in keys:
                v = b[key]
                out[key] = v + (s.view(-1, *[1] * (v.dim() - 1)) - 1) * grow * (v + k)
        return out

    def batch(self, pairs: np.ndarray) -> dict[str, torch.Tensor]:
        """Inputs x_t, controls c_{t+1}, targets x_{t+1} and c^d_{t+2} for windows (clip, start)."""
        clip = torch.from_numpy(pairs[:, 0]).to(self.x.device)
        g = self.clip_start[pairs[:, 0]] + pairs[:, 1]
        idx = torch.from_numpy(g[:, None] + np.arange(self.window)[None]).to(self.x.device)
        x, skel = self.x[idx], self.skel[clip]
        if self.hidden_inputs:  # only an ablation pays for the masks
            x, skel = x * self._x_shown, skel * self._skel_shown
        return dict(x=x, traj=self.traj[idx + 1], skel=skel, types=self.types[clip], target_x=self.x[idx + 1],
                    target_traj=self.traj[idx + 2], varying=self.varying)
