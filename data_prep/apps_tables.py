"""``python -m data_prep apps-tables --model ccnet_wide [--quick]``: CCNet paper Table 1
(denoising) and the trajectory-following distances of §4.3.2, for a CCNet named on the command
line against the committed baselines, written to ``results/``.

- ``results/ccnet_table1_denoising.csv`` (dataset, noise_std, model, mean, std, n):
  :mod:`mocapviz.tasks.denoising` on "D" (every test-split clip) and "S-CMU" (every CMU clip of
  the dataset: see below), noise 0.03 / 0.05 / 0.1 in normalised units, CCNet, ERD-4LR,
  DAE-LSTM, plus ``noisy_input`` (the error of the noisy frames themselves).
- ``results/ccnet_trajectory_following.csv`` (model, mean_cm, std_cm, n, covered):
  :mod:`mocapviz.tasks.trajectory_following` over the six paths and every locomotion test clip's
  first 120 frames, CCNet, PFNN, ERD-4LR, mean output.

S-CMU. The paper trained its three models again on a selected CMU set (its supplementary, not
available, says how). Our dataset holds 15 CMU clips of 14 subjects and none of them is in the
test split (no CMU subject has two clips long enough to hold one out), and there is no time to
train three more models here: so S-CMU is every CMU clip of the dataset, which **all three
models saw in training**. It measures denoising on other bodies than Bandai's one skeleton, in
sample, not on held-out data as the paper's.

Quick mode (``--quick``): the quick dataset (HDM05 + CMU + 3 Bandai takes per content: the same
HDM05/CMU split, a smaller Bandai share) and at most 8 trajectory seeds; full mode: the full
dataset and every locomotion test clip. The models are the committed checkpoints either way.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

NOISE_STDS = (0.03, 0.05, 0.1)
QUICK_SEEDS = 8


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", default="ccnet_wide", help="the CCNet: a name in models/zoo or a .safetensors file")
    p.add_argument("--erd", default="erd_quick")
    p.add_argument("--dae", default="dae_lstm_quick")
    p.add_argument("--pfnn", default="pfnn_quick")
    p.add_argument("--quick", action="store_true", help="quick dataset, at most 8 trajectory seeds")
    p.add_argument("--only", choices=("denoising", "trajectory"), help="one table only")
    p.add_argument("--out-dir", default=None, help="where the CSVs go (default results/)")
    p.add_argument("--data-dir")


def load_models(names: dict[str, str]) -> dict:
    """{label: (model, normaliser)} of checkpoint names or files (``mocapviz.zoo.find_checkpoint``)."""
    from data_prep.sources import REPO_ROOT
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.zoo import find_checkpoint

    out = {}
    for label, name in names.items():
        model, norm, _ = load_checkpoint(find_checkpoint(name, cwd=REPO_ROOT))
        out[label] = (model.eval(), norm)
    return out


def dataset(quick: bool, data_dir=None, n_types: int | None = None):
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset

    ds = build_dataset(DatasetConfig.quick() if quick else DatasetConfig(), data_dir, progress=False)
    return ds if n_types is None or n_types == len(ds.motion_types) else ds.with_vocabulary(n_types)


def denoising_clips(ds) -> dict[str, list[dict]]:
    """The clips of "D" (test split), "S-CMU" (every CMU clip, in training: see above) and
    "S-CMU-test" (the CMU clips of the test split), at least 2 frames each; and "val" (the
    validation split, where the causal smoother's k is chosen)."""
    c = ds.clips
    long = (c.stop - c.start) >= 2
    pick = {"D": (c.split == "test") & long, "S-CMU": (c.source == "cmu") & long,
            "S-CMU-test": (c.source == "cmu") & (c.split == "test") & long, "val": (c.split == "val") & long}
    return {k: [ds.clip_arrays(int(i)) for i in c.index[m.values]] for k, m in pick.items()}


def denoising_table(models: dict, ds, noise_stds=NOISE_STDS, seed: int = 0, progress: bool = False):
    """Table 1 rows for every dataset of :func:`denoising_clips` but "val", with the predictors
    that do nothing (:mod:`mocapviz.tasks.do_nothing`; the smoother's k and degree chosen on the
    validation clips per noise level); the first model's normaliser is the reference units."""
    import pandas as pd

    from mocapviz.tasks.denoising import Repairer, denoising_errors, summary_table
    from mocapviz.tasks.do_nothing import ConstantVelocity, CopyLast, choose_smoother

    ref = next(iter(models.values()))[1]
    reps = {k: Repairer(m, n, reference=ref) for k, (m, n) in models.items()}
    reps.update({b.name: b for b in (CopyLast(ref), ConstantVelocity(ref))})
    clips = denoising_clips(ds)
    val = clips.pop("val")
    smoothers = {}
    for std in noise_stds:
        s = choose_smoother(ref, val, std, seed=seed)[0]
        smoothers[std] = {f"causal_smoother(k={s.k},d={s.degree})": s}
    tables = [summary_table(denoising_errors(reps, cl, noise_stds, seed=seed, progress=progress,
                                             per_noise=smoothers.__getitem__), name)
              for name, cl in clips.items() if cl]
    return pd.concat(tables, ignore_index=True)


def thin(rows: list[int], n: int) -> list[int]:
    """At most ``n`` of ``rows``, evenly spread, first and last kept (quick mode's seeds)."""
    if len(rows) <= n:
        return list(rows)
    return [rows[int(round(j * (len(rows) - 1) / (n - 1)))] for j in range(n)]


def following_results(models: dict, ds, max_seeds: int | None = None, progress: bool = False):
    """Every model along every trajectory from the same seeds (each (model, path) one batch)."""
    from mocapviz.tasks import trajectory_following as tf

    rows = tf.seed_rows(ds) if max_seeds is None else thin(tf.seed_rows(ds), max_seeds)
    speeds = tf.type_speeds(ds)
    out = []
    for label, (model, norm) in models.items():
        for name in tf.TRAJECTORIES:
            out.append(tf.follow(model, norm, ds, rows, name, speeds, model_name=label, progress=progress))
    return out


def run(a: argparse.Namespace) -> int:
    import torch

    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.trajectory_following import following_table

    torch.set_num_threads(1)
    out_dir = Path(a.out_dir) if a.out_dir else REPO_ROOT / "results"
    out_dir.mkdir(parents=True, exist_ok=True)
    mode = "quick" if a.quick else "full"
    t0 = time.perf_counter()
    models = load_models({k: k for k in dict.fromkeys([a.model, a.erd, a.dae, a.pfnn])})
    ds = dataset(a.quick, a.data_dir, models[a.model][0].cfg.n_types)
    if a.only != "trajectory":
        table = denoising_table({k: models[k] for k in (a.model, a.erd, a.dae)}, ds, progress=True)
        table.to_csv(out_dir / "ccnet_table1_denoising.csv", index=False, float_format="%.4f")
        print(f"denoising ({mode}, {time.perf_counter() - t0:.0f} s):\n{table.to_string(index=False)}")
    if a.only != "denoising":
        results = following_results({k: models[k] for k in (a.model, a.pfnn, a.erd)}, ds,
                                    QUICK_SEEDS if a.quick else None, progress=True)
        table = following_table(results)
        table.to_csv(out_dir / "ccnet_trajectory_following.csv", index=False, float_format="%.2f")
        print(f"trajectory following ({mode}, {time.perf_counter() - t0:.0f} s):\n{table.to_string(index=False)}")
    return 0
