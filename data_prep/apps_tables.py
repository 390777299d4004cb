"""``python -m data_prep apps-tables [--model NAME ...] [--quick]``: CCNet paper Table 1
(denoising), Fig. 4(c-d) completion on the held-out subject and the trajectory-following
distances of §4.3.2, for the CCNets named on the command line (default: the next-frame model and
the generate command's model) against the committed baselines and the predictors that do
nothing, written to ``results/`` (each row carries the ``mode`` and ``command`` that made it).

- ``results/ccnet_table1_denoising.csv`` (dataset, noise_std, model, mean, std, n):
  :mod:`mocapviz.tasks.denoising` on "D" (every test-split clip) and "S-CMU" (every CMU clip of
  the dataset: see below), noise 0.03 / 0.05 / 0.1 in normalised units; the CCNets, ERD-4LR,
  DAE-LSTM, copy-last, constant velocity and the causal smoother (:mod:`mocapviz.tasks.do_nothing`;
  its window and degree chosen on the validation clips for each noise level), plus
  ``noisy_input`` (the error of the noisy frames themselves, which see the frame they are scored on).
- ``results/ccnet_completion_tr.csv`` (model, clips, frames, corrupted_cm, completed_cm): the
  held-out subject's right leg zeroed on 30 % of the frames, before and after completion.
- ``results/ccnet_table7_seed_length.csv`` (model, seed_frames, rel_p, n): Table 7, the one-step
  prediction after seeds of 1-120 frames (:mod:`mocapviz.tasks.seed_length`) on the "D" clips.
- ``results/ccnet_trajectory_following.csv`` (model, mean_cm, std_cm, n, covered, timed_cm,
  timed_std_cm): :mod:`mocapviz.tasks.trajectory_following` over the six paths and every
  locomotion test clip's first 120 frames; the CCNets, PFNN, ERD-4LR (mean output) and standing still.

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
# the next-frame CCNet (the tables' model) and the generate command's model
DEFAULT_CCNETS = ("ccnet_paper", "ccnet_generate")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", action="append", help="a CCNet: a name in models/zoo or a .safetensors file "
                   f"(repeatable; default {', '.join(DEFAULT_CCNETS)}); the first sets the units")
    p.add_argument("--erd", default="erd_quick")
    p.add_argument("--dae", default="dae_lstm_quick")
    p.add_argument("--pfnn", default="pfnn_quick")
    p.add_argument("--quick", action="store_true", help="quick dataset, at most 8 trajectory seeds")
    p.add_argument("--only", choices=("denoising", "completion", "seed-length", "trajectory"), help="one table only")
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


def completion_table(models: dict, ds, share: float = 0.3, segment: int = 30, seed: int = 0):
    """Fig. 4(c-d) on every test clip of the held-out subject (``ds.meta["test_subject"]``) long
    enough for the dropped runs: the right leg's rotations zeroed on ``share`` of the frames, each
    model's teacher-forced completion. Rows (model, clips, frames, corrupted_cm, completed_cm):
    the leg's mean joint error on the dropped frames before and after; ``copy_last`` and
    ``constant_velocity`` (:mod:`mocapviz.tasks.do_nothing`) complete it as well."""
    import numpy as np
    import pandas as pd

    from mocapviz.tasks.denoising import Repairer, complete_leg
    from mocapviz.tasks.do_nothing import ConstantVelocity, CopyLast

    c = ds.clips
    rows = np.flatnonzero(((c.split == "test") & (c.subject == ds.meta["test_subject"])
                           & (c.stop - c.start > 4 * segment)).values)
    ref = next(iter(models.values()))[1]
    reps = {k: Repairer(m, n, reference=ref) for k, (m, n) in models.items()}
    reps.update({b.name: b for b in (CopyLast(ref), ConstantVelocity(ref))})
    out = []
    for name, rep in reps.items():
        before, after = [], []
        for r in rows:
            res = complete_leg(rep, ds.clip_arrays(int(r)), ds.skeleton(int(r)), share=share, segment=segment, seed=seed)
            before.append(res["corrupted_error"][res["dropped"]])
            after.append(res["completed_error"][res["dropped"]])
        b, a = np.concatenate(before), np.concatenate(after)
        out.append(dict(model=name, clips=len(rows), frames=len(b), corrupted_cm=float(b.mean()),
                        completed_cm=float(a.mean())))
    return pd.DataFrame(out)


def seed_length_rows(models: dict, ds):
    """Table 7 (:mod:`mocapviz.tasks.seed_length`) on the clips of "D", the models and the
    predictors that do nothing."""
    from mocapviz.tasks.denoising import Repairer
    from mocapviz.tasks.do_nothing import ConstantVelocity, CopyLast
    from mocapviz.tasks.seed_length import seed_length_table

    ref = next(iter(models.values()))[1]
    reps = {k: Repairer(m, n, reference=ref) for k, (m, n) in models.items()}
    reps.update({b.name: b for b in (CopyLast(ref), ConstantVelocity(ref))})
    return seed_length_table(reps, denoising_clips(ds)["D"])


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
    ccnets = a.model or list(DEFAULT_CCNETS)
    models = load_models({k: k for k in dict.fromkeys([*ccnets, a.erd, a.dae, a.pfnn])})
    n_types = {models[k][0].cfg.n_types for k in ccnets}
    if len(n_types) > 1:
        raise ValueError(f"the CCNets know different motion-type vocabularies ({sorted(n_types)}): compare them apart")
    ds = dataset(a.quick, a.data_dir, n_types.pop())
    command = f"python -m data_prep apps-tables {' '.join(f'--model {m}' for m in ccnets)}{' --quick' if a.quick else ''}"

    def write(table, name, fmt):
        # every results file says how it was made: mode and command as columns
        table.assign(mode=mode, command=command).to_csv(out_dir / name, index=False, float_format=fmt)
        print(f"{name} ({mode}, {time.perf_counter() - t0:.0f} s):\n{table.to_string(index=False)}")

    if a.only in (None, "denoising"):
        write(denoising_table({k: models[k] for k in (*ccnets, a.erd, a.dae)}, ds, progress=True),
              "ccnet_table1_denoising.csv", "%.4f")
    if a.only in (None, "completion"):
        write(completion_table({k: models[k] for k in (*ccnets, a.erd, a.dae)}, ds), "ccnet_completion_tr.csv", "%.2f")
    if a.only in (None, "seed-length"):
        write(seed_length_rows({k: models[k] for k in (*ccnets, a.erd, a.dae)}, ds), "ccnet_table7_seed_length.csv",
              "%.5f")
    if a.only in (None, "trajectory"):
        results = following_results({k: models[k] for k in (*ccnets, a.pfnn, a.erd)}, ds,
                                    QUICK_SEEDS if a.quick else None, progress=True)
        write(following_table(results), "ccnet_trajectory_following.csv", "%.2f")
    return 0
