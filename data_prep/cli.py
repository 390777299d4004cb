"""``python -m data_prep {catalog,build,download,known-rests,train,...}`` (the rest in ``MODULE_COMMANDS``): see ``--help`` of each subcommand."""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

from data_prep.sources import SOURCES, DataNotFoundError


def _catalog(args) -> int:
    import pandas as pd

    from data_prep.catalog import CACHE_DIR, build_catalog, summary_table
    cat = build_catalog(args.data_dir, cache=not args.no_cache, sources=SOURCES)
    table = summary_table(cat)
    with pd.option_context("display.width", 200, "display.max_columns", 60, "display.max_rows", 200):
        for source, sub in table.groupby(level="source", sort=False):
            sub = sub.droplevel("source")
            types = [t for t in dict.fromkeys(sub.columns.get_level_values(0))
                     if t == "total" or sub[(t, "clips")].sum() > 0]
            cells = pd.DataFrame({t: [f"{c}/{f}/{s:.1f}s" if c else "-" for c, f, s in
                                      zip(sub[(t, "clips")], sub[(t, "frames")], sub[(t, "seconds")])]
                                  for t in types}, index=sub.index)
            print(f"\n{source}: clips/frames/seconds per subject and motion type")
            print(cells.T.to_string())
    n_bad = int((~cat.trainable).sum())
    print(f"\n{len(cat)} clips, {cat.frames.sum()} frames, {cat.duration_s.sum() / 60:.1f} min; "
          f"{n_bad} too short for training windows (trainable = False). Data: {cat.attrs['data_dir']}")
    out = Path(args.csv) if args.csv else CACHE_DIR / "catalog.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    cat.to_csv(out, index=False)
    print(f"catalog written to {out}")
    return 0


def _build(args) -> int:
    from data_prep.build import load_plugins, run_builds
    if args.list:
        for name, t in load_plugins().items():
            print(f"{name:12s} {'(default) ' if t.default else ''}{t.help}")
        return 0
    run_builds(args.targets, data_dir=args.data_dir, quick=args.quick)
    return 0


def _download(args) -> int:
    from data_prep.download import download
    done = download(args.source or None, args.dest, mirror=args.mirror,
                    accept_license=args.accept_license, force=args.force)
    for source, paths in done.items():
        print(f"{source}: {len(paths)} files in {Path(args.dest) / source}")
    return 0


def _known_rests(args) -> int:
    from data_prep.ccnet_dataset import write_known_rests
    from data_prep.sources import find_data_dir
    print(f"written {write_known_rests(find_data_dir(args.data_dir))}")
    return 0


# subcommands whose module has add_arguments(parser) and run(args) -> int: name, module, help
MODULE_COMMANDS = (
    ("train", "data_prep.train", "train a model on the CCNet dataset (see data_prep/train.py)"),
    ("fit-type-prior", "data_prep.type_prior", "fit a latent CCNet's prior of z given the motion type and write "
     "it beside the checkpoint (see data_prep/type_prior.py)"),
    ("apps-tables", "data_prep.apps_tables", "CCNet Table 1 (denoising), completion, Table 7 and trajectory "
     "following against the baselines into results/ (see data_prep/apps_tables.py)"),
    ("pack-ccnet", "data_prep.pack", "a compact copy of the CCNet dataset (~30 MB) for a machine without the raw "
     "data, e.g. a lent GPU (see data_prep/pack.py)"),
    ("one-step", "data_prep.one_step_report", "teacher-forced one-step error of CCNet models on held-out clips "
     "beside copy-last and constant velocity (see data_prep/one_step_report.py)"),
    ("generation-table", "data_prep.generation_table", "long free-running generation of CCNet models measured "
     "on poses into results/ccnet_generation.csv (see data_prep/generation_table.py)"),
    ("train-cvae", "data_prep.train_cvae", "train the 4D motion CVAE (phases 1, 2, ablations) or write its "
     "reconstruction table (see data_prep/train_cvae.py)"),
    ("finetune-table", "data_prep.finetune_table", "CCNet Table 5: fine-tuning on the unseen subject tr, rel_p "
     "(see data_prep/finetune_table.py)"),
    ("unseen-body", "data_prep.unseen_body_table", "CCNet Figs. 9-10: walking and trajectory following for tr with "
     "its legs scaled by 0.8 ('7b'), the seed-to-generation jump and the feet against the floor, into "
     "results/ccnet_unseen_body.csv (see data_prep/unseen_body_table.py)"),
    ("ccnet-ablations", "data_prep.ccnet_ablations", "CCNet's ablations (Figs. 11-12): CRL, NCF, w/o ROT, Smooth, SK, "
     "LSTMs for SRBs, into results/ccnet_ablations.csv (see data_prep/ccnet_ablations.py)"),
    ("cvae4d-prediction", "data_prep.cvae4d_prediction", "4D motion prediction (paper 2 §5): train Residual-sup "
     "or write results/cvae4d_prediction.csv (see data_prep/cvae4d_prediction.py)"),
)


def parser() -> argparse.ArgumentParser:
    from data_prep.download import DEFAULT_DEST
    p = argparse.ArgumentParser(prog="python -m data_prep", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)

    c = sub.add_parser("catalog", help="print a summary of the data and write cache/catalog.csv")
    c.add_argument("--data-dir", help="data folder (default: the search order of data_prep.sources)")
    c.add_argument("--csv", help="where to write the catalog (default cache/catalog.csv)")
    c.add_argument("--no-cache", action="store_true", help="rescan the files, ignore the cache")
    c.set_defaults(func=_catalog)

    b = sub.add_parser("build", help="build datasets (default: every default target, e.g. catalog)")
    b.add_argument("targets", nargs="*", help="build targets by name (see --list)")
    b.add_argument("--data-dir")
    b.add_argument("--quick", action="store_true", help="small builds for tests and quick mode")
    b.add_argument("--list", action="store_true", help="list the build targets")
    b.set_defaults(func=_build)

    d = sub.add_parser("download", help="download the motion data (see data_prep/download.py)")
    d.add_argument("--source", action="append", choices=SOURCES,
                   help="source to fetch (repeatable; default: all whose license needs no acceptance)")
    d.add_argument("--dest", default=str(DEFAULT_DEST), help="destination folder (default data/raw)")
    d.add_argument("--mirror", help="base URL of a copy of the reference data folder (exact copies)")
    d.add_argument("--accept-license", action="store_true",
                   help="accept the academic-only license of Human3.6M (required to fetch h36m)")
    d.add_argument("--force", action="store_true", help="download again even if files exist")
    d.set_defaults(func=_download)

    k = sub.add_parser("known-rests", help="write mocapviz/features/known_rests.json: the rest re-basing the "
                       "dataset gives Bandai's skeleton, so that the generate command prepares a Bandai file alike")
    k.add_argument("--data-dir", default=None)
    k.set_defaults(func=_known_rests)

    for name, module, help_text in MODULE_COMMANDS:
        mod = importlib.import_module(module)
        sp = sub.add_parser(name, help=help_text)
        mod.add_arguments(sp)
        sp.set_defaults(func=mod.run)
    return p


def main(argv=None) -> int:
    from data_prep.download import DownloadError
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except (DataNotFoundError, DownloadError, KeyError) as e:
        msg = e.args[0] if isinstance(e, KeyError) and e.args else e
        print(f"error: {msg}", file=sys.stderr)
        return 2
