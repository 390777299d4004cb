"""``python -m data_prep generation-table [--model NAME ...] [--frames 20000]``: the CCNet paper's
long-generation claim measured on poses, for each model, mean output and sampled, into
``results/ccnet_generation.csv``.

Each of the ten test seeds of :func:`mocapviz.tasks.generation_quality.locomotion_seeds` (48 seed
frames) runs free for ``--frames`` frames (20,000: 5.6 minutes at 60 fps); the second half is
measured by :func:`mocapviz.tasks.generation_quality.generation_quality`: freezing share,
activity, jitter, pose distance, root speed and height, each as a ratio to the real clips of the
seed's motion type. Rows (model, mode, clip, type, the quality keys, within_bar, moves_like_real,
mode, command). Sampling uses the generate command's temperature.
"""

from __future__ import annotations

import time
from pathlib import Path

DEFAULT_MODELS = ("ccnet_default", "ccnet_paper", "ccnet_generate")


def add_arguments(p) -> None:
    p.add_argument("--model", action="append", help=f"zoo name or file (repeatable; default {', '.join(DEFAULT_MODELS)})")
    p.add_argument("--frames", type=int, default=20_000, help="generated frames per seed")
    p.add_argument("--out", default=None, help="CSV path (default results/ccnet_generation.csv)")


def run(a) -> int:
    import pandas as pd
    import torch

    from data_prep.apps_tables import load_models
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.generation_defaults import SAMPLING_TEMPERATURE
    from mocapviz.tasks.generation_quality import TypeBanks, generation_quality, moves_like_real, within_issue_bar

    torch.set_num_threads(1)
    names = a.model or list(DEFAULT_MODELS)
    out = Path(a.out) if a.out else REPO_ROOT / "results" / "ccnet_generation.csv"
    command = f"python -m data_prep generation-table {' '.join(f'--model {m}' for m in names)} --frames {a.frames}"
    ds = build_dataset(DatasetConfig())
    banks = TypeBanks(ds)
    rows = []
    for name, (model, norm) in load_models({m: m for m in names}).items():
        dsv = ds if model.cfg.n_types == len(ds.motion_types) else ds.with_vocabulary(model.cfg.n_types)
        for sample in (False, True):
            t0 = time.perf_counter()
            q = generation_quality(model, norm, dsv, a.frames / dsv.config.fps, sample,
                                   temperature=SAMPLING_TEMPERATURE if sample else 1.0, banks=banks)
            for clip, m in q["per_clip"].items():
                rows.append(dict(model=name, mode="sampled" if sample else "mean", clip=clip,
                                 **{k: v for k, v in m.items()}, within_bar=within_issue_bar(m),
                                 moves_like_real=moves_like_real(m)))
            print(f"{name} {'sampled' if sample else 'mean'}: {time.perf_counter() - t0:.0f} s; "
                  f"within the moving bar {sum(within_issue_bar(m) for m in q['per_clip'].values())}/{len(q['per_clip'])}",
                  flush=True)
    table = pd.DataFrame(rows).assign(frames=a.frames, command=command)
    table.to_csv(out, index=False, float_format="%.4f")
    print(table.groupby(["model", "mode"])[["freezing_share", "activity_ratio", "jitter_ratio", "within_bar",
                                            "moves_like_real"]].mean().round(3).to_string())
    return 0
