"""Training windows of a CCNet dataset: normalised arrays and a sampler of (clip, start) windows."""

from __future__ import annotations

import numpy as np
import torch

from mocapviz.features.motion_types import one_hot
from mocapviz.features.phase import clip_phases


class WindowData:
    """Normalised arrays of a CCNet dataset and a sampler of training windows.

    ``ds`` is a :class:`mocapviz.datasets.ccnet.CCNetDataset` (anything with the same fields).
    Every model on the CCNet features (CCNet, and the recurrent baselines) trains on these
    batches; a batch's keys are the models' ``input_names`` plus the targets.
    """

    def __init__(self, ds, window: int, normaliser=None, phase: bool = False):
        norm = normaliser or ds.normaliser
        self.window = window
        self.layout = ds.layout
        self.x = torch.from_numpy(norm.norm_x(ds.x))
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
        # validation (the whole held-out actor mm by default, 43 clips): every window (stride 1),
        # so every frame counts at every context length; ~3400 windows, a few seconds per evaluation
        self.val = ds.window_starts("val", window, stride=1)
        self.n_train_frames = int(sum(r.stop - r.start for r in ds.clips.itertuples() if r.split == "train"))
        self.train_types = ds.clips.type_index.values[self.train[:, 0]]
        self._draw_p: dict[float, np.ndarray] = {}   # type_balance -> window probabilities

    def draw_train(self, rng: np.random.Generator, n: int, type_balance: float = 0.0) -> np.ndarray:
        """``n`` training windows drawn with replacement: uniformly (``type_balance`` 0), or each
        weighted by 1 / (training windows of its motion type)^type_balance, so 1 draws every type
        equally often (in dataset v4 walks are 62 % of the 60-frame windows, hops 0.2 %)."""
        if not type_balance:
            return self.train[rng.integers(len(self.train), size=n)]
        if type_balance not in self._draw_p:  # once per run, not every step
            counts = np.bincount(self.train_types)
            w = counts[self.train_types].astype(np.float64) ** -type_balance
            self._draw_p[type_balance] = w / w.sum()
        return self.train[rng.choice(len(self.train), size=n, p=self._draw_p[type_balance])]

    def batch(self, pairs: np.ndarray) -> dict[str, torch.Tensor]:
        """Inputs x_t, controls c_{t+1}, targets x_{t+1} and c^d_{t+2} for windows (clip, start)."""
        clip = pairs[:, 0]
        g = self.clip_start[clip] + pairs[:, 1]
        idx = torch.from_numpy(g[:, None] + np.arange(self.window)[None])
        return dict(x=self.x[idx], traj=self.traj[idx + 1], skel=self.skel[clip], types=self.types[clip],
                    target_x=self.x[idx + 1], target_traj=self.traj[idx + 2], varying=self.varying)
