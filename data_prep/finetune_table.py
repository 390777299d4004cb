"""``python -m data_prep finetune-table [--quick]``: CCNet paper Table 5 (§4.6), fine-tuning on an
unseen skeleton, into ``results/ccnet_table5_finetune.csv``.

The held-out HDM05 subject ``tr`` (the dataset's test subject, never seen in training) is the
novel skeleton. Its clips are split on their own (:func:`mocapviz.tasks.finetune.finetune_split`):
fine-tuning on its locomotion, with one sneak clip held back for validation (it picks the
checkpoint; no scored clip does), and rel_p of one-step prediction (the mean output, the past
being the true frames) on every one of its clips of another motion type. HDM05 has no plain walk
for ``tr``: its locomotion is ``sneak`` (our stand-in for the paper's "W") and
``jogLeftCircle...`` (``jog``, for "R"). Fine-tuning sets: sneak alone (W) and sneak and jog (W
and R), as the paper's two FT columns.

Rows: the CCNet (``ccnet_paper``, the paper's next-frame network) without fine-tuning and
fine-tuned on each set; ERD-4LR and DAE-LSTM without fine-tuning and fine-tuned on sneak and jog
(a fine-tune keeps DAE-LSTM's pretrained autoencoder; its LSTM and decoder train);
copy-last and constant velocity (:mod:`mocapviz.tasks.do_nothing`) on the same frames.
CCNet-D1 / CCNet-D2 (trained from scratch on training subjects close to / far from tr in size)
need two more full trainings (each 80 CPU minutes as ccnet_paper was) and are written as rows
not run, with the reason in ``note``.

Fine-tuning: :func:`mocapviz.training.trainer.train` with ``init`` (the network and its
normaliser), the model's own training config (``mocapviz.zoo.MODELS``) with its learning rate
(start and end) times ``--lr-scale`` (0.1), ``--steps`` optimiser steps (CCNet, default 400) or
``--baseline-steps`` (ERD-4LR and DAE-LSTM, default 400), one CPU thread, about ten evaluations on the
validation clip; run folders in ``cache/runs/finetune_table5/``; the best-by-validation
checkpoint is scored. A fixed step count, not a wall-clock budget (``--minutes`` gives one):
on a shared machine a budget's steps depend on the load. Each row records the minutes of tr's
motion its fine-tuning saw, its steps, CPU and wall minutes, and the validation NLL before and
after; ``rel_p_val`` is rel_p on the held-back validation clip (locomotion, the kind of motion
fine-tuning saw), beside ``rel_p`` on the test clips (every other kind).

Quick mode (``--quick``): the quick dataset (the same HDM05 clips, so the same ``tr`` clips),
``--steps 2`` per fine-tune unless given: a smoke test of the command, not a result.
"""

from __future__ import annotations

import argparse
import shutil
import time
from dataclasses import replace
from pathlib import Path

OUT_NAME = "ccnet_table5_finetune.csv"
COLUMNS = ("model", "finetuned", "fine_tuning", "rel_p", "rel_p_std", "n_frames", "n_clips", "rel_p_val", "ft_clips",
           "ft_minutes_of_motion", "ft_steps", "ft_cpu_minutes", "ft_wall_minutes", "ft_val_nll_init",
           "ft_val_nll_best", "note", "mode", "dataset", "command")
NOT_RUN = ("not run: a CCNet trained from scratch on {}; two more full trainings (80 CPU minutes each, as "
           "ccnet_paper) do not fit this run's budget on a shared 2-core machine")
D_ROWS = {"CCNet-D1": "training subjects close to tr in size", "CCNet-D2": "training subjects far from tr in size"}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", default="ccnet_paper", help="the CCNet (zoo name or .safetensors file)")
    p.add_argument("--erd", default="erd_quick")
    p.add_argument("--dae", default="dae_lstm_quick")
    p.add_argument("--steps", type=int, help="optimiser steps of each CCNet fine-tune (default 400; quick 2)")
    p.add_argument("--baseline-steps", type=int, help="... of the ERD-4LR and DAE-LSTM fine-tunes (default 400; "
                   "quick 2; 0: none)")
    p.add_argument("--minutes", type=float, help="instead of steps: a wall-clock budget per fine-tune "
                   "(TrainConfig.minutes; on a shared machine its steps depend on the load)")
    p.add_argument("--lr-scale", type=float, default=0.1, help="the model's own learning rate times this")
    p.add_argument("--quick", action="store_true", help="quick dataset, 2 steps per fine-tune: a smoke test")
    p.add_argument("--out", help=f"the CSV (default results/{OUT_NAME})")
    p.add_argument("--runs-dir", help="fine-tuning run folders (default cache/runs/finetune_table5)")
    p.add_argument("--data-dir")


def finetune_config(cfg, steps: int, lr_scale: float, minutes: float | None = None):
    """The training config of a fine-tune: the model's own ``cfg`` (``mocapviz.zoo.MODELS``) with
    its learning rate (start and end) times ``lr_scale``, one CPU thread, ``steps`` optimiser steps
    (or a wall-clock budget of ``minutes``), about ten evaluations on the validation clip."""
    cfg = replace(cfg, lr=cfg.lr * lr_scale, lr_final=cfg.lr_final * lr_scale, threads=1, device="cpu")
    if minutes:
        return replace(cfg, steps=10 ** 6, minutes=minutes, eval_every=1, checkpoint_every=1)
    every = max(1, steps // 10)
    return replace(cfg, steps=steps, minutes=0.0, eval_every=every, checkpoint_every=every)


def fine_tune(init_name: str, sub, cfg, out_dir: Path) -> dict:
    """Fine-tune ``init_name`` on ``sub``'s train split into a fresh ``out_dir``: the best-by-
    validation (model, normaliser) and what it cost."""
    import torch

    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.training.runs import BEST, LOG, best_row, read_log
    from mocapviz.training.trainer import evaluate, train
    from mocapviz.training.windows import WindowData
    from mocapviz.zoo import find_checkpoint

    from data_prep.sources import REPO_ROOT

    init = find_checkpoint(init_name, cwd=REPO_ROOT)
    model0, norm0, _ = load_checkpoint(init)
    data = WindowData(replace(sub, normaliser=norm0), cfg.window)
    with torch.no_grad():
        val0 = evaluate(model0.float(), data, data.val, cfg.lambdas, kl_weight=cfg.kl_weight)["nll"]
    if out_dir.exists():
        shutil.rmtree(out_dir)   # a time-budgeted run cannot resume: always from the pretrained network
    cpu0, wall0 = time.process_time(), time.perf_counter()
    train(sub, cfg, out_dir, resume=False, progress=False, init=init)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    rows = read_log(out_dir / LOG)
    best = best_row(rows)
    model, norm, _ = load_checkpoint(out_dir / BEST)
    return dict(model=model.float().eval(), norm=norm, ft_steps=int(rows[-1]["step"]), ft_cpu_minutes=cpu / 60,
                ft_wall_minutes=wall / 60, ft_val_nll_init=float(val0), ft_val_nll_best=float(best["val_nll"]),
                best_step=int(best["step"]))


def table5(ds, models: dict, finetune: list[tuple[str, str]], cfgs: dict, runs_dir: Path, progress=print):
    """The rows of Table 5 (:data:`COLUMNS` but mode, dataset, command). ``models``: label ->
    (model, normaliser, zoo name), the first the CCNet whose normaliser sets the units;
    ``finetune``: (label, set name of :data:`mocapviz.tasks.finetune.FINETUNE_SETS`) to fine-tune,
    with ``cfgs[label]`` its config."""
    import pandas as pd

    from mocapviz.tasks import finetune as ft
    from mocapviz.tasks.denoising import Repairer
    from mocapviz.tasks.do_nothing import ConstantVelocity, CopyLast

    subject = ds.meta["test_subject"]
    subs = {name: ft.finetune_split(ds, subject, types, not_tested=ft.LOCOMOTION)
            for name, types in ft.FINETUNE_SETS.items()}
    first = next(iter(subs.values()))
    test, val = ft.split_clips(first, "test"), ft.split_clips(first, "val")   # the same in every set
    ref = next(iter(models.values()))[1]
    reps = {k: Repairer(m, n, reference=ref) for k, (m, n, _) in models.items()}
    reps.update({b.name: b for b in (CopyLast(ref), ConstantVelocity(ref))})
    def scored(reps):   # rel_p on the test clips, and on the held-back validation clip (locomotion)
        return ft.rel_p_table(reps, test).assign(rel_p_val=ft.rel_p_table(reps, val).rel_p.values)

    base = scored(reps).assign(finetuned=False, fine_tuning="none")
    rows = [base]
    for label, set_name in finetune:
        sub = subs[set_name]
        n_train, held = int((sub.clips.split == "train").sum()), sub.clips["clip"][sub.clips.split == "val"].tolist()
        progress(f"fine-tuning {label} on {set_name}: {ft.motion_minutes(sub):.2f} min of {subject}'s motion "
                 f"({n_train} clips), validation {held}")
        run_dir = runs_dir / f"{Path(label).stem}_{'_'.join(ft.FINETUNE_SETS[set_name])}"
        res = fine_tune(models[label][2], sub, cfgs[label], run_dir)
        t = scored({label: Repairer(res["model"], res["norm"], reference=ref)})
        extra = {k: res[k] for k in ("ft_steps", "ft_cpu_minutes", "ft_wall_minutes", "ft_val_nll_init",
                                     "ft_val_nll_best")}
        rows.append(t.assign(finetuned=True, fine_tuning=set_name, ft_clips=n_train,
                             ft_minutes_of_motion=ft.motion_minutes(sub), note=f"best of step {res['best_step']}",
                             **extra))
        progress(rows[-1].to_string(index=False))
    rows.append(pd.DataFrame([dict(model=k, finetuned=False, fine_tuning="none", note=NOT_RUN.format(v))
                              for k, v in D_ROWS.items()]))
    out = pd.concat(rows, ignore_index=True)
    out["n_clips"] = len(test)
    return out


def run(a: argparse.Namespace) -> int:
    import torch

    from data_prep.apps_tables import dataset, load_models
    from data_prep.sources import REPO_ROOT
    from mocapviz.zoo import MODELS

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    mode = "quick" if a.quick else "full"
    names = {a.model: a.model, a.erd: a.erd, a.dae: a.dae}
    loaded = load_models(names)
    models = {k: (m, n, names[k]) for k, (m, n) in loaded.items()}
    ds = dataset(a.quick, a.data_dir, models[a.model][0].cfg.n_types)

    def own_config(name: str, model):
        from mocapviz.training.config import TRAIN_CONFIGS
        key = Path(name).stem
        if key in MODELS:
            return MODELS[key]
        return replace(TRAIN_CONFIGS["quick"], model=model.name)

    steps = a.steps if a.steps is not None else (2 if a.quick else 400)
    baseline_steps = a.baseline_steps if a.baseline_steps is not None else (2 if a.quick else 400)
    cfgs = {a.model: finetune_config(own_config(a.model, models[a.model][0]), steps, a.lr_scale, a.minutes)}
    plan = [(a.model, s) for s in ("walk (sneak)", "walk and run (sneak, jog)")]
    if baseline_steps > 0:
        for name in (a.erd, a.dae):
            cfgs[name] = finetune_config(own_config(name, models[name][0]), baseline_steps, a.lr_scale, a.minutes)
            plan.append((name, "walk and run (sneak, jog)"))
    runs_dir = Path(a.runs_dir) if a.runs_dir else REPO_ROOT / "cache" / "runs" / "finetune_table5"
    table = table5(ds, models, plan, cfgs, runs_dir)
    command = "python -m data_prep finetune-table" + (" --quick" if a.quick else "") + "".join(
        f" --{k.replace('_', '-')} {v:g}" for k, v in (("steps", a.steps), ("baseline_steps", a.baseline_steps),
                                                       ("minutes", a.minutes), ("lr_scale", a.lr_scale))
        if v is not None and not (k == "lr_scale" and v == 0.1))
    table = table.assign(mode=mode, dataset=ds.meta.get("hash"), command=command)
    table = table.reindex(columns=list(COLUMNS))
    out = Path(a.out) if a.out else REPO_ROOT / "results" / OUT_NAME
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False, float_format="%.5g")
    import pandas as pd
    with pd.option_context("display.width", 250, "display.max_columns", 30, "display.max_colwidth", 40):
        print(table.drop(columns=["command", "dataset"]).to_string(index=False))
    print(f"written {out} ({mode}, {time.perf_counter() - t0:.0f} s)")
    return 0
