"""``python -m data_prep train-cvae``: train the 4D motion CVAE, its ablations, and write the
reconstruction table (multi-frame 4D motion paper §3.3, §4.2-4.4).

    python -m data_prep train-cvae --phase 1 --export            # cvae4d_phase1 (config phase1)
    python -m data_prep train-cvae --phase 2 --export            # cvae4d_phase2 from cvae4d_phase1
    python -m data_prep train-cvae --ablations                   # latent 8..128, KL 0.001/0.1 (phase 1),
                                                                 # then results/cvae4d_ablations.csv
    python -m data_prep train-cvae --table                       # results/cvae4d_reconstruction.csv

Runs go to ``cache/cvae4d/<name>/`` (``model.safetensors``, ``losses.csv``); ``--export`` also
writes ``models/zoo/<name>.safetensors`` (float16 weights, 2.6 MB) and ``<name>_losses.csv``.
The reconstruction table evaluates PCA and the two committed checkpoints on every test set; its
``checkpoint`` column is the sha256 (16 hex digits) of the file each row evaluated, so a test can
tell that the table is current. The ablation table holds one row per test cycle and model.
The dataset is ``python -m data_prep build body4d`` (``--dataset quick``: its quick config).
``--config paper_phase1`` / ``paper_phase2``: the paper's schedule and wider layers, for a GPU.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

ABLATIONS = {f"cvae4d_z{z}": dict(latent=z) for z in (8, 16, 32, 64, 128)}
ABLATIONS.update({f"cvae4d_kl{k}": dict(kl_weight=k) for k in (0.001, 0.1)})
ABLATION_EPOCHS = 300  # quick (CPU budget): a tenth of the committed phase-1 run's epochs, the same for every ablation
TABLE = Path("results") / "cvae4d_reconstruction.csv"
ABLATION_TABLE = Path("results") / "cvae4d_ablations.csv"
TABLE_MODELS = ("cvae4d_phase1", "cvae4d_phase2")


def add_arguments(p: argparse.ArgumentParser) -> None:
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--phase", type=int, choices=(1, 2), help="train one phase")
    what.add_argument("--ablations", action="store_true",
                      help=f"train the ablation models (phase 1), write {ABLATION_TABLE}")
    what.add_argument("--table", action="store_true", help=f"evaluate the committed models, write {TABLE}")
    p.add_argument("--config", help="named config (mocapviz.training.cvae4d.CVAE_CONFIGS; default phase<N>)")
    p.add_argument("--name", help="run name (default cvae4d_phase<N>)")
    p.add_argument("--init", default="cvae4d_phase1", help="phase 2: the phase-1 model (zoo name or file)")
    p.add_argument("--epochs", type=int)
    p.add_argument("--latent", type=int)
    p.add_argument("--kl", type=float, help="KL weight (default 0.01)")
    p.add_argument("--vertex-subset", type=int, help="phase 2: vertices in the loss (0 = all)")
    p.add_argument("--dataset", choices=("full", "quick"), default="full")
    p.add_argument("--data-dir")
    p.add_argument("--export", action="store_true", help="also write models/zoo/<name>.safetensors (+ losses)")


def _dataset(a):
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    return build_dataset(Body4DConfig.quick() if a.dataset == "quick" else Body4DConfig(), a.data_dir)


def _train_one(ds, name: str, cfg, init, export: bool) -> Path:
    from data_prep.catalog import CACHE_DIR
    from data_prep.zoo import ZOO_DIR
    from mocapviz.training.cvae4d import dataset_meta, save_cvae, train, write_log

    model, rows = train(ds, cfg, init=init[0] if init else None)
    run = CACHE_DIR / "cvae4d" / name
    meta = dict(train_config=cfg.to_json(), dataset=dataset_meta(ds), phase=str(cfg.phase),
                epochs=str(cfg.epochs), seconds=str(rows[-1]["seconds"]),
                init=init[1] if init else "", command=f"python -m data_prep train-cvae {_command(name, cfg)}")
    save_cvae(run / "model.safetensors", model, meta)
    write_log(run / "losses.csv", rows)
    last = rows[-1]
    held = {k: v for k, v in last.items() if k.startswith("held_")}
    print(f"{name}: phase {cfg.phase}, {cfg.epochs} epochs in {last['seconds']:.0f} s; last epoch "
          f"{ {k: last[k] for k in last if k in ('pose', 'trans', 'spatial', 'time', 'kl')} }; held-out {held}")
    if export:
        dest = save_cvae(ZOO_DIR / f"{name}.safetensors", model, meta, half=True)
        shutil.copyfile(run / "losses.csv", ZOO_DIR / f"{name}_losses.csv")
        print(f"exported {dest} ({dest.stat().st_size / 1e6:.1f} MB)")
    return run


def _command(name: str, cfg) -> str:
    return f"--phase {cfg.phase} --name {name} --epochs {cfg.epochs} --latent {cfg.latent} --kl {cfg.kl_weight}"


def run(a: argparse.Namespace) -> int:
    from mocapviz.training.cvae4d import CVAE_CONFIGS, load_cvae, with_overrides

    if a.table:
        return write_table(a)
    ds = _dataset(a)
    if a.ablations:
        runs = {}
        for name, kw in ABLATIONS.items():
            cfg = with_overrides(CVAE_CONFIGS["phase1"], epochs=a.epochs or ABLATION_EPOCHS, **kw)
            runs[name] = _train_one(ds, name, cfg, None, a.export) / "model.safetensors"
        return write_ablation_table(ds, runs)
    cfg = with_overrides(CVAE_CONFIGS[a.config or f"phase{a.phase}"], phase=a.phase, epochs=a.epochs,
                         latent=a.latent, kl_weight=a.kl, vertex_subset=a.vertex_subset)
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
    """Evaluate PCA and the committed CVAEs (:data:`TABLE_MODELS`) on every test set; write :data:`TABLE`."""
    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.cvae4d_eval import error_table, load_checkpoints, reconstruction_errors
    from mocapviz.zoo import find_checkpoint

    ds = _dataset(a)
    paths = {n: find_checkpoint(n) for n in TABLE_MODELS}
    errors = reconstruction_errors(ds, load_checkpoints(ds, paths), progress=True)
    table = error_table(errors)
    table["checkpoint"] = [checkpoint_id(paths[m]) if m in paths else "" for m in table["model"]]
    out = REPO_ROOT / TABLE
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False)
    print(table.to_string(index=False))
    print(f"written {out} (dataset {a.dataset}, {ds.meta.get('hash')})")
    return 0


def write_ablation_table(ds, paths: dict) -> int:
    """Per-sequence errors (mm) of the ablation models (name -> checkpoint) on every test set:
    :data:`ABLATION_TABLE` (model, latent, kl_weight, epochs, test_set, cycle, error_mm)."""
    import pandas as pd

    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.cvae4d_eval import load_checkpoints, reconstruction_errors, test_sets

    models = load_checkpoints(ds, paths)
    errors = reconstruction_errors(ds, models, progress=True)
    sets = test_sets(ds)
    frames = []
    for (name, t), err in errors.items():
        if name == "pca":
            continue
        cfg = models[name].cfg
        train_cfg = _train_config(paths[name])
        frames.append(pd.DataFrame(dict(model=name, latent=cfg.latent, kl_weight=train_cfg["kl_weight"],
                                        epochs=train_cfg["epochs"], test_set=t, cycle=sets[t],
                                        error_mm=err.round(2))))
    out = REPO_ROOT / ABLATION_TABLE
    pd.concat(frames, ignore_index=True).to_csv(out, index=False)
    print(f"written {out}")
    return 0


def _train_config(path) -> dict:
    from mocapviz.training.cvae4d import load_cvae
    return load_cvae(path)[1]["train_config"]
