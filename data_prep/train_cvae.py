"""``python -m data_prep train-cvae``: train the 4D motion CVAE, its ablations, and write the
reconstruction table (multi-frame 4D motion paper §3.3, §4.2-4.4).

    python -m data_prep train-cvae --phase 1 --export            # cvae4d_phase1 (config phase1)
    python -m data_prep train-cvae --phase 2 --export            # cvae4d_phase2 from cvae4d_phase1
    python -m data_prep train-cvae --ablations                   # latent 8..128, KL 0.001/0.1 (short phase-1
                                                                 # runs), then results/cvae4d_ablations.csv
    python -m data_prep train-cvae --table                       # results/cvae4d_reconstruction.csv
    python -m data_prep train-cvae --alpha-sweep                 # GradNorm's alpha on the validation
                                                                 # cycles: results/cvae4d_alpha_sweep.csv
    python -m data_prep train-cvae --phase 1 --lr-end 0.05       # learning rate decayed on a cosine to a
                                                                 # twentieth (default: constant)

Runs go to ``cache/cvae4d/<name>/`` (``model.safetensors``, ``losses.csv``); ``--export`` also
writes ``models/zoo/<name>.safetensors`` (float16 weights, 13 MB) and ``<name>_losses.csv``.
The reconstruction table evaluates PCA, the training-mean cycle, the two committed checkpoints
and, when trained here, their second-seed runs on every test set; its ``checkpoint`` column is the sha256 (16 hex digits) of the file each row evaluated, so a test can
tell that the table is current. The ablation runs go to ``cache/runs/abl_<name>/`` and are
never exported; a finished run with the same config and data is reused, so the command only
evaluates when every run exists (delete a run's folder to retrain it). The ablation table holds
Tukey summaries per (ablation, value, test set), plus "all" (every test cycle).
The dataset is ``python -m data_prep build body4d`` (``--dataset quick``: its quick config).
``--config paper_phase1`` / ``paper_phase2``: the paper's schedule and wider layers, for a GPU.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

# Figs. 3-4: run name -> (ablation, value, config overrides). cvae4d_z64 (latent 64, KL 0.01) is the
# reference of both figures, trained the same short way as the others.
ABLATIONS = {f"cvae4d_z{z}": ("latent", z, dict(latent=z)) for z in (8, 16, 32, 64, 128)}
ABLATIONS.update({f"cvae4d_kl{k}": ("kl_weight", k, dict(kl_weight=k)) for k in (0.001, 0.1)})
ABLATION_REFERENCE = {"latent": 64, "kl_weight": 0.01}  # the committed models' values: cvae4d_z64's
# Short runs: 80 epochs, a fifth of the committed phase-1 run's 405, the same for every ablation. At
# widths (256, 256) a phase-1 epoch took 3-4 wall s on one thread of a shared machine (~4.5 min a
# run, ~32 min for the seven): the session's budget set the number, not convergence.
ABLATION_EPOCHS = 80
ABLATION_COMMAND = "python -m data_prep train-cvae --ablations"
TABLE = Path("results") / "cvae4d_reconstruction.csv"
ABLATION_TABLE = Path("results") / "cvae4d_ablations.csv"
# GradNorm's alpha is chosen on the validation cycles by short phase-1 runs (the ablations' length):
# the lowest mean vertex error wins ...
SWEEP_ALPHAS = (0.5, 1.0, 1.5)
# ... among the alphas whose weights never went SWEEP_MAX_RATIO apart (the issue's bar; logged beside): 1.5's
# short runs went 31x and 19x apart (two builds of the same data)
SWEEP_MAX_RATIO = 10.0
# ... neither in the short run nor in the full-length phase-1 runs trained at that alpha: the ratio keeps
# growing after 80 epochs (alpha 1.0: 9.2x at 80, past 10x from epoch 110, 25.7x and 25.1x by 700 in
# two seeds). alpha -> the loss logs of those runs (the committed model's, and alpha 1.0's, kept here)
FULL_LENGTH_LOGS = {0.5: ["models/zoo/cvae4d_phase1_losses.csv"],
                    1.0: ["results/cvae4d_alpha1_phase1_seed0_losses.csv", "results/cvae4d_alpha1_phase1_seed1_losses.csv"]}
SWEEP_TABLE = Path("results") / "cvae4d_alpha_sweep.csv"
SWEEP_COMMAND = "python -m data_prep train-cvae --alpha-sweep"
TABLE_MODELS = ("cvae4d_phase1", "cvae4d_phase2")
FIT_PER_SET = 40  # cycles per test set whose codes are fitted (a fit costs ~100 encoder passes)


def add_arguments(p: argparse.ArgumentParser) -> None:
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--phase", type=int, choices=(1, 2), help="train one phase")
    what.add_argument("--ablations", action="store_true",
                      help=f"train the ablation models (phase 1), write {ABLATION_TABLE}")
    what.add_argument("--table", action="store_true", help=f"evaluate the committed models, write {TABLE}")
    what.add_argument("--alpha-sweep", action="store_true",
                      help=f"short phase-1 runs at each GradNorm alpha of {SWEEP_ALPHAS}, scored on the "
                           f"validation cycles: {SWEEP_TABLE}")
    p.add_argument("--config", help="named config (mocapviz.training.cvae4d.CVAE_CONFIGS; default phase<N>)")
    p.add_argument("--name", help="run name (default cvae4d_phase<N>)")
    p.add_argument("--init", default="cvae4d_phase1", help="phase 2: the phase-1 model (zoo name or file)")
    p.add_argument("--epochs", type=int)
    p.add_argument("--latent", type=int)
    p.add_argument("--kl", type=float, help="KL weight (default 0.01)")
    p.add_argument("--vertex-subset", type=int, help="phase 2: vertices in the loss (0 = all)")
    p.add_argument("--minutes", type=float, help="wall-clock budget (0: train every epoch)")
    p.add_argument("--seed", type=int, help="training seed (default 0)")
    p.add_argument("--alpha", type=float, help="GradNorm asymmetry (default: the config's)")
    p.add_argument("--lr-end", type=float, help="the learning rate at the end as a fraction of the start (cosine "
                   "decay; default 1: constant)")
    p.add_argument("--balance-types", type=float, help="draws within a body times (its cycles of the type)^-this "
                   "(default 0: by body only)")
    p.add_argument("--dataset", choices=("full", "quick"), default="full")
    p.add_argument("--data-dir")
    p.add_argument("--export", action="store_true", help="also write models/zoo/<name>.safetensors (+ losses)")


def _dataset(a):
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    return build_dataset(Body4DConfig.quick() if a.dataset == "quick" else Body4DConfig(), a.data_dir)


def _train_one(ds, name: str, cfg, init, export: bool, run: Path | None = None, command: str = "") -> Path:
    from data_prep.catalog import CACHE_DIR
    from data_prep.zoo import ZOO_DIR
    from mocapviz.training.cvae4d import dataset_meta, save_cvae, train, write_log

    model, rows = train(ds, cfg, init=init[0] if init else None)
    run = run or CACHE_DIR / "cvae4d" / name
    meta = dict(train_config=cfg.to_json(), dataset=dataset_meta(ds), phase=str(cfg.phase),
                epochs=str(cfg.epochs), seconds=str(rows[-1]["seconds"]),
                init=init[1] if init else "",
                command=command or f"python -m data_prep train-cvae {_command(name, cfg)}")
    save_cvae(run / "model.safetensors", model, meta)
    write_log(run / "losses.csv", rows)
    last = rows[-1]
    val = {k: v for k, v in last.items() if k.startswith("val_") or k == "kept_epoch"}
    print(f"{name}: phase {cfg.phase}, {cfg.epochs} epochs in {last['seconds']:.0f} s; last epoch "
          f"{ {k: last[k] for k in last if k in ('pose', 'trans', 'spatial', 'time', 'kl')} }; validation {val}")
    if export:
        dest = save_cvae(ZOO_DIR / f"{name}.safetensors", model, meta, half=True)
        shutil.copyfile(run / "losses.csv", ZOO_DIR / f"{name}_losses.csv")
        print(f"exported {dest} ({dest.stat().st_size / 1e6:.1f} MB)")
    return run


def _command(name: str, cfg) -> str:
    return (f"--phase {cfg.phase} --name {name} --epochs {cfg.epochs} --latent {cfg.latent} --kl {cfg.kl_weight} "
            f"--minutes {cfg.minutes:g} --seed {cfg.seed} --alpha {cfg.alpha:g}"
            + (f" --lr-end {cfg.lr_end:g}" if cfg.lr_end != 1 else "")
            + (f" --balance-types {cfg.balance_types:g}" if cfg.balance_types else ""))


def run(a: argparse.Namespace) -> int:
    from mocapviz.training.cvae4d import CVAE_CONFIGS, load_cvae, with_overrides

    if a.table:
        return write_table(a)
    ds = _dataset(a)
    if a.ablations:
        return run_ablations(a, ds)
    if a.alpha_sweep:
        return run_alpha_sweep(a, ds)
    cfg = with_overrides(CVAE_CONFIGS[a.config or f"phase{a.phase}"], phase=a.phase, epochs=a.epochs,
                         latent=a.latent, kl_weight=a.kl, vertex_subset=a.vertex_subset, minutes=a.minutes,
                         seed=a.seed, alpha=a.alpha, lr_end=a.lr_end, balance_types=a.balance_types)
    init = None
    if a.phase == 2:
        from mocapviz.zoo import find_checkpoint
        path = find_checkpoint(a.init)
        init = (load_cvae(path)[0], str(a.init))
        print(f"phase 2 starts from {path}")
    _train_one(ds, a.name or f"cvae4d_phase{a.phase}", cfg, init, a.export)
    return 0


def checkpoint_id(path) -> str:
    """The first 16 hex digits of a checkpoint file's sha256 (the table's ``checkpoint`` column)."""
    import hashlib
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def write_table(a: argparse.Namespace) -> int:
    """Evaluate PCA and the committed CVAEs (:data:`TABLE_MODELS`) on every test set, then the same
    with each cycle's code fitted (Fig. 5's "z optimised" rows, on :data:`FIT_PER_SET` cycles per
    set, ``unfitted_mean`` the same model's mean on those cycles); write :data:`TABLE`."""
    import numpy as np

    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.cvae4d_eval import (FIT_SUFFIX, error_table, fit_subsets, fitted_reconstruction_errors,
                                            load_checkpoints, reconstruction_errors, test_sets)
    from mocapviz.zoo import find_checkpoint

    from data_prep.catalog import CACHE_DIR

    ds = _dataset(a)
    paths = {n: find_checkpoint(n) for n in TABLE_MODELS}
    # the second training seed's runs, when trained here: the run-to-run spread beside each model
    paths.update({f"{n}_seed1": CACHE_DIR / "cvae4d" / f"{n}_seed1" / "model.safetensors" for n in TABLE_MODELS
                  if (CACHE_DIR / "cvae4d" / f"{n}_seed1" / "model.safetensors").exists()})
    models = load_checkpoints(ds, paths)
    errors = reconstruction_errors(ds, models, progress=True, with_probes=True)
    committed = {n: models[n] for n in TABLE_MODELS}
    fitted = fitted_reconstruction_errors(ds, committed, FIT_PER_SET, progress=True)
    table = error_table({**errors, **fitted})
    everything, subsets = test_sets(ds), fit_subsets(ds, FIT_PER_SET)
    unfitted = {}
    for (name, t) in fitted:
        at = np.searchsorted(everything[t], subsets[t])
        unfitted[(name, t)] = round(float(errors[(name[:-len(FIT_SUFFIX)], t)][at].mean()), 2)
    table["unfitted_mean"] = [unfitted.get((m, t), np.nan) for m, t in zip(table.model, table.test_set)]
    ids = {n: checkpoint_id(p) for n, p in paths.items()}
    ids.update({n + FIT_SUFFIX: ids[n] for n in TABLE_MODELS})
    table["checkpoint"] = [ids.get(m, "") for m in table["model"]]
    table["dataset"] = ds.meta.get("hash")
    table["command"] = "python -m data_prep train-cvae --table" + (" --dataset quick" if a.dataset == "quick" else "")
    out = REPO_ROOT / TABLE
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False)
    print(table.to_string(index=False))
    print(f"written {out} (dataset {a.dataset}, {ds.meta.get('hash')})")
    return 0


def ablation_command(a: argparse.Namespace) -> str:
    """The command line that makes the ablation table with ``a``'s options (recorded in the table)."""
    extra = (f" --epochs {a.epochs}" if a.epochs else "") + (" --dataset quick" if a.dataset == "quick" else "")
    return ABLATION_COMMAND + extra


def ablation_settings() -> dict:
    """Run name -> [(ablation, value), ...]: the reference run (latent 64, KL 0.01) is in both figures."""
    out = {}
    for name, (ablation, value, _) in ABLATIONS.items():
        out[name] = [(ablation, value)]
        if value == ABLATION_REFERENCE[ablation]:
            out[name] += [(k, v) for k, v in ABLATION_REFERENCE.items() if k != ablation]
    return out


def _short_run(ds, name: str, cfg, run: Path, command: str) -> Path:
    """A short phase-1 run's checkpoint: reused when one with the same config and data exists."""
    from mocapviz.training.cvae4d import CVAETrainConfig, data_fingerprint, load_cvae

    path = run / "model.safetensors"
    if path.exists():
        meta = load_cvae(path)[1]
        if CVAETrainConfig(**meta["train_config"]) == cfg and meta["dataset"]["fingerprint"] == data_fingerprint(ds):
            print(f"{name}: reusing {path} ({meta['seconds']} s of training)")
            return path
    return _train_one(ds, name, cfg, None, export=False, run=run, command=command) / "model.safetensors"


def run_ablations(a: argparse.Namespace, ds) -> int:
    """Train (or reuse) the seven short phase-1 runs of :data:`ABLATIONS`, then write :data:`ABLATION_TABLE`."""
    from data_prep.catalog import CACHE_DIR
    from mocapviz.training.cvae4d import CVAE_CONFIGS, with_overrides

    command, paths = ablation_command(a), {}
    for name, (_, _, kw) in ABLATIONS.items():
        cfg = with_overrides(CVAE_CONFIGS["phase1"], epochs=a.epochs or ABLATION_EPOCHS, **kw)
        paths[name] = _short_run(ds, name, cfg, CACHE_DIR / "runs" / f"abl_{name}", command)
    return write_ablation_table(ds, paths, command)


def run_alpha_sweep(a: argparse.Namespace, ds) -> int:
    """Short phase-1 runs at each alpha of :data:`SWEEP_ALPHAS` (``--alpha``: that one only), scored
    by the mean vertex error on the validation cycles (never the test sets), beside the largest
    GradNorm weight ratio of any step; writes :data:`SWEEP_TABLE` once every alpha has a run."""
    import numpy as np
    import pandas as pd

    from data_prep.catalog import CACHE_DIR
    from data_prep.sources import REPO_ROOT
    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.torch_mesh import ChiMesher
    from mocapviz.tasks.cvae4d_eval import load_checkpoints, reconstruct_cvae, vertex_errors
    from mocapviz.training.cvae4d import CVAE_CONFIGS, load_cvae, validation_indices, with_overrides

    epochs = a.epochs or ABLATION_EPOCHS
    command = SWEEP_COMMAND + (f" --epochs {a.epochs}" if a.epochs else "")
    paths = {}
    for alpha in ([a.alpha] if a.alpha is not None else SWEEP_ALPHAS):
        cfg = with_overrides(CVAE_CONFIGS["phase1"], epochs=epochs, alpha=alpha, seed=a.seed)
        name = f"cvae4d_alpha{alpha:g}"
        paths[alpha] = _short_run(ds, name, cfg, CACHE_DIR / "runs" / f"sweep_{name}", command)
    if a.alpha is not None:
        return 0
    idx = validation_indices(ds)
    mesher = ChiMesher(body_model(), ds.gamma_scale)
    models = load_checkpoints(ds, {alpha: p for alpha, p in paths.items()})
    rows = []
    for alpha, model in models.items():
        err = vertex_errors(mesher, ds.chi[idx], reconstruct_cvae(model, ds.chi[idx], ds.beta[idx]), ds.beta[idx])
        log = pd.read_csv(paths[alpha].parent / "losses.csv")
        rows.append(dict(alpha=alpha, epochs=epochs, val_cycles=len(idx), val_mean_mm=round(float(err.mean()), 2),
                         val_median_mm=round(float(np.median(err)), 2),
                         w_ratio_max=float(log["w_ratio_max"].max()),
                         w_ratio_last_epoch=float(log["w_ratio_max"].iloc[-1]),
                         seconds=float(load_cvae(paths[alpha])[1]["seconds"])))
    table = pd.DataFrame(rows)
    table["w_ratio_max_full_length"] = [full_length_ratio(alpha) for alpha in table["alpha"]]
    worst = table[["w_ratio_max", "w_ratio_max_full_length"]].max(axis=1)  # NaN (no full run) is skipped
    balanced = table[worst < SWEEP_MAX_RATIO]
    table["chosen"] = table["alpha"] == balanced.loc[balanced["val_mean_mm"].idxmin(), "alpha"]
    table["dataset"], table["command"] = ds.meta.get("hash"), command
    out = REPO_ROOT / SWEEP_TABLE
    table.to_csv(out, index=False)
    print(table.drop(columns=["dataset", "command"]).to_string(index=False))
    print(f"written {out}")
    return 0


def full_length_ratio(alpha: float) -> float:
    """The largest GradNorm weight ratio at any step of the full-length phase-1 runs trained at
    ``alpha`` (:data:`FULL_LENGTH_LOGS`; NaN where there is none)."""
    import numpy as np
    import pandas as pd

    from data_prep.sources import REPO_ROOT

    logs = [pd.read_csv(REPO_ROOT / p) for p in FULL_LENGTH_LOGS.get(float(alpha), [])]
    return max((float(log["w_ratio_max"].max()) for log in logs), default=np.nan)


def write_ablation_table(ds, paths: dict, command: str) -> int:
    """Tukey summaries of the ablation runs (name -> checkpoint) on every test set and on all test
    cycles together: :data:`ABLATION_TABLE` (:func:`mocapviz.tasks.cvae4d_eval.ablation_table`
    columns, then epochs, dataset hash, the command)."""
    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.cvae4d_eval import ablation_table, load_checkpoints, reconstruction_errors

    models = load_checkpoints(ds, paths)
    errors = reconstruction_errors(ds, models, with_pca=False, progress=True)
    table = ablation_table(errors, ablation_settings())
    epochs = {name: int(_train_config(p)["epochs"]) for name, p in paths.items()}
    table["epochs"] = table["model"].map(epochs)
    table["dataset"] = ds.meta.get("hash")
    table["command"] = command
    out = REPO_ROOT / ABLATION_TABLE
    table.to_csv(out, index=False)
    print(table.drop(columns=["dataset", "command"]).to_string(index=False))
    print(f"written {out}")
    return 0


def _train_config(path) -> dict:
    from mocapviz.training.cvae4d import load_cvae
    return load_cvae(path)[1]["train_config"]
