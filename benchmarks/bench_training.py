"""Training speed, CCNet vs ERD-4LR at equal parameter count (the paper's case for causal convolutions).

    .venv/bin/python benchmarks/bench_training.py [--dataset quick] [--size default] [--batch 16]

One epoch (every training frame once: the training clips cut into non-overlapping windows, in
one seeded order) of CCNet and of ERD-4LR, in one run, on the same batches with the same input
noise: Adam steps of the training loss, this CPU, ``--threads`` threads. The two models' steps
alternate batch by batch, so that a shared machine's changing load falls on both alike. ERD-4LR's width
(encoder = LSTM = decoder units) is the one whose parameter count is closest to CCNet's.
Prints each model's seconds per epoch, frames per second and parameter count, and the ratio;
the last line is a JSON object.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np
import torch

from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from mocapviz.models.protocol import count_parameters, model_class
from mocapviz.training.config import TRAIN_CONFIGS
from mocapviz.training.losses import LOSSES
from mocapviz.training.windows import WindowData


def erd_of_size(n_params: int, layout):
    """The ERD-4LR whose parameter count is closest to ``n_params`` (one width for all layers)."""
    cls = model_class("erd")
    base = cls.config_for(replace(TRAIN_CONFIGS["quick"], model="erd"), layout)

    def count(w):
        return count_parameters(cls(replace(base, encoder=w, hidden=w, decoder=w)))

    lo, hi = 4, 2048
    while hi - lo > 1:      # the count grows with the width
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if count(mid) < n_params else (lo, mid)
    w = min((lo, hi), key=lambda v: abs(count(v) - n_params))
    return cls(replace(base, encoder=w, hidden=w, decoder=w))


class Timed:
    """A model, its Adam optimiser and the seconds its training steps took."""

    def __init__(self, model, lambdas, noise_std: float):
        self.model, self.lambdas, self.noise_std = model.train(), lambdas, noise_std
        self.opt = torch.optim.Adam(model.parameters(), lr=1e-4)
        self.loss_fn = LOSSES[model.name]
        self.seconds = 0.0

    def step(self, b: dict, noise: torch.Tensor) -> None:
        t = time.perf_counter()
        m = self.model
        out = m(**{k: (b[k] + self.noise_std * noise if k == "x" else b[k]) for k in m.input_names})
        loss = self.loss_fn(out, b, m.cfg, self.lambdas)["loss"]
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        self.opt.step()
        self.seconds += time.perf_counter() - t


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dataset", choices=("quick", "full"), default="quick")
    p.add_argument("--size", default="default", help="CCNet size (mocapviz.models.ccnet_config.SIZES)")
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--window", type=int, default=60)
    p.add_argument("--max-batches", type=int, default=0, help="stop the epoch after this many batches (0: all)")
    p.add_argument("--threads", type=int, default=1)
    a = p.parse_args(argv)
    torch.set_num_threads(a.threads)
    ds = build_dataset(DatasetConfig.quick() if a.dataset == "quick" else DatasetConfig(), progress=False)
    data = WindowData(ds, a.window)
    windows = ds.window_starts("train", a.window, stride=a.window)
    order = np.random.default_rng(0).permutation(len(windows))
    batches = []
    gen = torch.Generator().manual_seed(0)
    for i in range(0, len(order), a.batch):
        b = data.batch(windows[order[i:i + a.batch]])
        batches.append((b, torch.randn(b["x"].shape, generator=gen)))
    if a.max_batches:
        batches = batches[:a.max_batches]
    frames = sum(b["x"].shape[0] * b["x"].shape[1] for b, _ in batches)
    cfg = replace(TRAIN_CONFIGS["default"], size=a.size)
    torch.manual_seed(0)
    ccnet = model_class("ccnet")(cfg.model_config(data.layout))
    erd = erd_of_size(count_parameters(ccnet), data.layout)
    res = dict(dataset=a.dataset, windows=sum(len(b["x"]) for b, _ in batches), frames=frames,
               batch=a.batch, window=a.window, threads=a.threads, ccnet_size=a.size, erd_width=erd.cfg.hidden)
    timed = {name: Timed(m, cfg.lambdas, cfg.noise_std) for name, m in (("ccnet", ccnet), ("erd", erd))}
    for t in timed.values():          # warm-up, not timed
        for b, noise in batches[:2]:
            t.step(b, noise)
        t.seconds = 0.0
    for b, noise in batches:          # interleaved, so that both see the same load on a shared machine
        for t in timed.values():
            t.step(b, noise)
    for name, t in timed.items():
        res[f"{name}_params"] = count_parameters(t.model)
        res[f"{name}_epoch_s"] = round(t.seconds, 2)
        res[f"{name}_frames_per_s"] = round(frames / t.seconds, 1)
        print(f"{name:6s} {count_parameters(t.model):8d} parameters: one epoch ({len(batches)} batches, {frames} frames) "
              f"in {t.seconds:.1f} s, {frames / t.seconds:.0f} frames/s")
    res["erd_over_ccnet"] = round(res["erd_epoch_s"] / res["ccnet_epoch_s"], 2)
    print(f"CCNet is {res['erd_over_ccnet']:.2f}x faster per epoch than ERD-4LR (paper's claim: >= 5x)")
    print(json.dumps(res))
    return res


if __name__ == "__main__":
    main()
