"""``python -m data_prep.cvae4d_completion``: the 4D motion paper's completion experiments
(§6, Fig. 8, Table 1) with the committed CVAE on held-out cycles of the full body4d dataset,
written to ``results/cvae4d_completion.csv`` (see :mod:`mocapviz.tasks.cvae4d_completion`).

    python -m data_prep.cvae4d_completion                      # the committed table (full mode)
    python -m data_prep.cvae4d_completion --per-test-set 1 --steps 50 --no-full-batch --out /tmp/c.csv   # smoke
    python -m data_prep.cvae4d_completion --shard 0/2 & python -m data_prep.cvae4d_completion --shard 1/2
                                                               # the same table on two cores

Rows: M (points per frame; 0 = markers only), frames (observed), variant (points+markers,
points, markers), weighting (fixed, gradnorm), budget (minibatch: CompletionConfig's frames and
points per Adam step; full: every observed frame and point in each step, for M = 1000), mean_mm (mean over the cycles of the mean
Chamfer distance to the true meshes), n (cycles), seconds (mean CPU seconds of one fit).
Per-cycle errors go to ``cache/runs/comp_completion/rows.csv``. Run it on one thread
(``OMP_NUM_THREADS=1``); it sets torch's threads to 1. ``--shard K/N`` fits every N-th cycle from the
K-th in one process (each fit is seeded on its own, so the rows equal the unsharded run's); the
shard that finishes last writes the table from every shard's rows.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

TABLE = Path("results") / "cvae4d_completion.csv"
MODEL = "cvae4d_phase2"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m data_prep.cvae4d_completion", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", default=MODEL, help="committed CVAE (zoo name or file)")
    p.add_argument("--dataset", choices=("full", "quick"), default="full")
    p.add_argument("--per-test-set", type=int, default=12, help="held-out cycles drawn from each test set "
                   "(all of a smaller set)")
    p.add_argument("--no-full-batch", dest="full_batch", action="store_false",
                   help="skip the full-batch fits (every frame and point in each step; FULL_BATCH_FITS)")
    p.add_argument("--steps", type=int, help="Adam steps per fit (default: CompletionConfig's)")
    p.add_argument("--noise", type=float, default=0.0, help="std (m) of Gaussian noise on points and markers")
    p.add_argument("--shard", default="0/1", help="K/N: this process fits every N-th cycle from the K-th (0-based)")
    p.add_argument("--data-dir")
    p.add_argument("--out", default=str(TABLE))
    a = p.parse_args(argv)
    shard, shards = _shard(p, a.shard)

    import pandas as pd
    import torch

    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    from data_prep.catalog import CACHE_DIR
    from mocapviz.tasks.cvae4d_completion import (FULL_BATCH_FITS, CompletionConfig, pick_sequences, run_completion,
                                                  summary)
    from mocapviz.tasks.cvae4d_eval import on_scale
    from mocapviz.zoo import load_cvae4d

    torch.set_num_threads(1)
    model, meta = load_cvae4d(a.model)
    model.eval()
    ds = build_dataset(Body4DConfig.quick() if a.dataset == "quick" else Body4DConfig(), a.data_dir)
    ds = on_scale(ds, meta["dataset"]["gamma_scale"])
    cfg = CompletionConfig() if a.steps is None else CompletionConfig(steps=a.steps)
    idx = pick_sequences(ds, a.per_test_set)
    mine = idx[shard::shards]
    t0 = time.process_time()
    run = CACHE_DIR / "runs" / "comp_completion"
    run.mkdir(parents=True, exist_ok=True)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    own = run / ("rows.csv" if shards == 1 else f"rows.{shard}of{shards}.csv")
    own.unlink(missing_ok=True)
    parts = []
    for i in mine:  # one cycle at a time: this shard's rows so far are on disk after each
        parts.append(run_completion(model, ds, [i], cfg=cfg, noise_std=a.noise).drop(columns=["chi", "beta"]))
        if a.full_batch:
            parts.append(run_completion(model, ds, [i], FULL_BATCH_FITS, cfg=cfg, noise_std=a.noise,
                                        budget="full").drop(columns=["chi", "beta"]))
        rows = pd.concat(parts, ignore_index=True)
        rows.to_csv(own.with_suffix(".partial"), index=False)
        if shards == 1:
            summary(rows).to_csv(a.out, index=False)
    own.with_suffix(".partial").rename(own)
    print(f"{len(mine)} of {len(idx)} cycles {mine.tolist()}, {len(rows)} fits, {cfg}; "
          f"{time.process_time() - t0:.0f} CPU s (mean {rows.seconds.mean():.1f} s per fit)")
    done = [run / f"rows.{k}of{shards}.csv" for k in range(shards)] if shards > 1 else [own]
    if not all(f.exists() for f in done):
        print(f"shard {shard}/{shards} done; the table is written by the last shard to finish")
        return 0
    rows = pd.concat([pd.read_csv(f) for f in done], ignore_index=True)
    if shards > 1:
        rows.to_csv(run / "rows.csv", index=False)
    table = summary(rows)
    table.to_csv(a.out, index=False)
    print(table.to_string(index=False))
    print(f"{rows.cycle.nunique()} cycles, {len(rows)} fits; wrote {a.out}")
    return 0


def _shard(p, text: str) -> tuple[int, int]:
    try:
        k, n = (int(v) for v in text.split("/"))
    except ValueError:
        p.error(f"--shard is K/N (e.g. 0/2), got {text!r}")
    if not 0 <= k < n:
        p.error(f"--shard K/N needs 0 <= K < N, got {text!r}")
    return k, n


if __name__ == "__main__":
    raise SystemExit(main())
