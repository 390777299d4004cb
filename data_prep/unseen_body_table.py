"""``python -m data_prep unseen-body [--quick]``: CCNet paper §4.6, Figs. 9-10 (generation for a
body no one captured, "7b") measured, into ``results/ccnet_unseen_body.csv``.

7b is the held-out subject ``tr`` with its lower body scaled by 0.8; the seeds are the first 120
frames of tr's locomotion clips long enough for them (its four ``jogLeftCircle`` clips; its sneaks
are 94-99 frames), retargeted onto 7b (:mod:`mocapviz.tasks.unseen_body`). Each model
(``ccnet_paper``, ``ccnet_generate``, ``erd_quick``, ``pfnn_quick``; mean output) continues
them:

- ``walk``: ``--seconds`` (10) of type walk on the network's own c^d;
- ``follow``: the curved paths of ``--path`` (s_curve and circle) with the trajectory task's
  machinery (:func:`mocapviz.tasks.trajectory_following.follow`, its speeds and distances).

Rows (body, task, model, pipeline): ``jump`` (:func:`~mocapviz.tasks.unseen_body.seam_jump`, mean
over seeds; ``jump_max``; ``jump_pose``, the same without the body's height), ``penetration_cm`` (the mean depth of the
generated frames' lowest joint under the seed's floor; ``penetration_1s_cm`` over the first
generated second) and ``foot_height_cm`` (its median height over the floor, mean over seeds), for
``follow`` the trajectory distances (``distance_cm`` mean ± std over (seed, path), ``covered``,
``timed_cm``). Rows that do nothing: ``real_clip`` (the seed clip itself, cut at every frame:
what no jump scores; its feet over the whole clip), ``copy_last`` (the last seed pose held: a
freeze scores jump 0), ``stand_still`` (the trajectory task's). ``pipeline`` "network" feeds
the seed straight to the network (the paper's test, 7b's c^s as it is); "generate command"
(``ccnet_generate``, walk only) goes through the generate command's
:func:`~mocapviz.tasks.generate_bvh.generate_from_seed`. Body "tr" (factor 1, the subject's own
legs) is the control: what the same seeds do without the scaling.

Quick mode (``--quick``): the quick dataset (the same tr clips), one seed, 2 s of walking, 7b
and s_curve only: a smoke test, not a result.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

OUT_NAME = "ccnet_unseen_body.csv"
MODELS = ("ccnet_paper", "ccnet_generate", "erd_quick", "pfnn_quick")
PATHS = ("s_curve", "circle")
BODIES = {"7b": 0.8, "tr": 1.0}    # name -> lower-body factor
COLUMNS = ("body", "task", "model", "pipeline", "n_seeds", "jump", "jump_max", "jump_pose", "penetration_cm",
           "penetration_1s_cm", "foot_height_cm", "distance_cm", "distance_std_cm", "covered", "timed_cm",
           "generated_s", "paths", "seeds", "mode", "command")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", action="append", help=f"zoo name (repeatable; default {', '.join(MODELS)})")
    p.add_argument("--seconds", type=float, default=10.0, help="seconds of walking after each seed")
    p.add_argument("--path", action="append", help=f"trajectory (repeatable; default {', '.join(PATHS)})")
    p.add_argument("--quick", action="store_true", help="quick dataset, one seed, 2 s, 7b and s_curve only")
    p.add_argument("--out", help=f"the CSV (default results/{OUT_NAME})")
    p.add_argument("--data-dir")


def body_rows(models: dict, ds, rows: list[int], body: str, factor: float, seconds: float, paths) -> list[dict]:
    """The rows of one body (see the module docstring); ``models``: name -> (model, normaliser, meta)."""
    import numpy as np

    from mocapviz.tasks import trajectory_following as tf
    from mocapviz.tasks import unseen_body as ub
    from mocapviz.tasks.rig import floor_height

    bds = ub.body_dataset(ds, rows, factor)
    seeds = list(range(len(rows)))
    base = dict(body=body, n_seeds=len(rows), seeds=" ".join(bds.clips["clip"]))
    n_seed, n_gen = ub.SEED_FRAMES, int(round(seconds * ds.config.fps))
    real = [bds.clip_motion(k) for k in seeds]
    cuts, pose_cuts = ([ub.real_cut_jump(m, height=h) for m in real] for h in (True, False))
    ground = [ub.foot_ground(m.positions(), floor_height(m.positions())) for m in real]
    out = [dict(base, task="walk", model="real_clip", pipeline="-", jump=float(np.mean(cuts)),
                jump_max=float(np.max(cuts)), jump_pose=float(np.mean(pose_cuts)),
                **{k: float(np.mean([g[k] for g in ground])) for k in ground[0]})]
    held = [ub.held_last(m[:n_seed], n_gen) for m in real]   # the last seed pose held: the do-nothing walk
    out.append(dict(base, task="walk", model="copy_last", pipeline="-", generated_s=seconds,
                    **ub.measure(held, n_seed)))
    speeds = tf.type_speeds(ds)
    follows = []
    for name, (model, norm, meta) in models.items():
        t0 = time.perf_counter()
        out.append(dict(base, task="walk", model=name, pipeline="network", generated_s=seconds,
                        **ub.measure(ub.walk_motions(model, norm, bds, seeds, seconds), n_seed)))
        if name == "ccnet_generate":
            out.append(dict(base, task="walk", model=name, pipeline="generate command", generated_s=seconds,
                            **ub.measure(ub.command_motions(model, norm, meta, bds, seeds, seconds), n_seed)))
        runs = [tf.follow(model, norm, bds, seeds, p, speeds, model_name=name, keep=True) for p in paths]
        follows += runs
        m = [ub.measure(ub.follow_motions(r, bds), n_seed) for r in runs]
        out.append(dict(base, task="follow", model=name, pipeline="network", paths=" ".join(paths),
                        generated_s=float(np.mean([r.achieved.shape[1] for r in runs]) / ds.config.fps),
                        **{k: float(np.mean([x[k] for x in m])) for k in m[0]}))
        out[-1]["jump_max"] = float(np.max([x["jump_max"] for x in m]))
        print(f"{body} {name}: {time.perf_counter() - t0:.0f} s", flush=True)
    dist = tf.following_table(follows).set_index("model")
    for r in out:
        if r["task"] == "follow":
            d = dist.loc[r["model"]]
            r.update(distance_cm=d.mean_cm, distance_std_cm=d.std_cm, covered=d.covered, timed_cm=d.timed_cm)
    d = dist.loc["stand_still"]
    out.append(dict(base, task="follow", model="stand_still", pipeline="-", paths=" ".join(paths),
                    distance_cm=d.mean_cm, distance_std_cm=d.std_cm, covered=d.covered, timed_cm=d.timed_cm))
    return out


def run(a: argparse.Namespace) -> int:
    import pandas as pd
    import torch

    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from data_prep.sources import REPO_ROOT
    from data_prep.zoo import load
    from mocapviz.tasks import unseen_body as ub

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    names = a.model or list(MODELS)
    paths = a.path or (["s_curve"] if a.quick else list(PATHS))
    seconds = 2.0 if a.quick else a.seconds
    bodies = {"7b": BODIES["7b"]} if a.quick else BODIES
    ds = build_dataset(DatasetConfig.quick() if a.quick else DatasetConfig(), a.data_dir, progress=False)
    rows = ub.seed_rows(ds)[:1 if a.quick else None]
    models = {n: load(n, progress=False) for n in names}
    if {m.cfg.n_types for m, _, _ in models.values()} != {len(ds.motion_types)}:
        raise ValueError(f"every model must know the dataset's {len(ds.motion_types)} motion types")
    command = ("python -m data_prep unseen-body" + "".join(f" --model {n}" for n in names)
               + "".join(f" --path {p}" for p in paths) + f" --seconds {seconds:g}" + (" --quick" if a.quick else ""))
    rows_out = []
    for body, factor in bodies.items():
        rows_out += body_rows(models, ds, rows, body, factor, seconds, paths)
    table = pd.DataFrame(rows_out).assign(mode="quick" if a.quick else "full", command=command)
    table = table.reindex(columns=list(COLUMNS))
    out = Path(a.out) if a.out else REPO_ROOT / "results" / OUT_NAME
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False, float_format="%.3f")
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(table.drop(columns=["seeds", "command", "paths"]).to_string(index=False))
    print(f"written {out} ({time.perf_counter() - t0:.0f} s)")
    return 0
