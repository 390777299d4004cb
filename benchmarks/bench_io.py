"""Reader throughput: mocapviz vs PyPI peers on the same real files, and catalog build time.

Usage: .venv/bin/python benchmarks/bench_io.py [--repeats 3] [--amc-step 2] [--bandai-step 10]

Every reader parses the same files from disk in one process; each peer does its own full
parse (pybvh.read_bvh_file, bvhio.readAsBvh, bvh.Bvh(text) — the `bvh` package only
tokenises, keeping values as strings —, pyacclaim.loadASF+loadAMC, fairmotion's asfamc.load
when it imports; set FAIRMOTION_PATH to a folder from `pip install --no-deps --target DIR
fairmotion` to include it). MB/s = bytes of the motion files / best of N wall times. The
last line printed is a JSON summary.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from data_prep.catalog import build_catalog  # noqa: E402
from data_prep.sources import find_data_dir  # noqa: E402
from mocapviz.io.asfamc import read_amc, read_asf  # noqa: E402
from mocapviz.io.bvh import read_bvh  # noqa: E402

warnings.simplefilter("ignore")


def best_time(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        with contextlib.redirect_stdout(io.StringIO()):
            fn()
        best = min(best, time.perf_counter() - t)
    return best


def _is_utf8(path: Path) -> bool:
    try:
        path.read_bytes().decode("utf-8")
        return True
    except UnicodeDecodeError:
        return False


def bvh_readers():
    # Our Motion converts Euler angles to matrices on first use; "+matrices" forces that
    # work too, for a like-for-like view against readers that convert eagerly.
    readers = {"mocapviz": lambda p: read_bvh(p), "mocapviz+matrices": lambda p: read_bvh(p).rotations}
    with contextlib.suppress(ImportError):
        import pybvh
        readers["pybvh"] = lambda p: pybvh.read_bvh_file(p, world_up="+y")
    with contextlib.suppress(ImportError):
        import bvhio
        readers["bvhio"] = lambda p: bvhio.readAsBvh(str(p))
    with contextlib.suppress(ImportError):
        import bvh
        readers["bvh"] = lambda p: bvh.Bvh(Path(p).read_text())
    return readers


def time_bvh_readers(files: list[Path], label: str, repeats: int) -> dict[str, float]:
    """MB/s of every BVH reader on ``files`` (best of ``repeats`` for ours and pybvh, else 1)."""
    mb = sum(p.stat().st_size for p in files) / 1e6
    print(f"BVH: {len(files)} {label} files, {mb:.2f} MB, best of {repeats}")
    rates = {}
    for name, fn in bvh_readers().items():
        reps = repeats if name.startswith("mocapviz") or name == "pybvh" else 1
        try:
            t = best_time(lambda: [fn(p) for p in files], reps)
        except Exception as err:  # noqa: BLE001 - a peer that cannot read these files
            print(f"  {name:12s} failed: {err!r}"[:200])
            continue
        rates[name] = mb / t
        print(f"  {name:12s} {rates[name]:8.1f} MB/s  ({t:.3f} s)")
    return rates


def amc_readers(skip: dict):
    def ours(asf_path, amc_paths, matrices=False):
        asf = read_asf(asf_path)
        for p in amc_paths:
            motion = read_amc(p, asf)
            if matrices:
                motion.rotations  # noqa: B018 (forces the Euler conversion)
    readers = {"mocapviz": ours, "mocapviz+matrices": lambda a, ps: ours(a, ps, matrices=True)}
    try:
        import pyacclaim.parser as pa

        def acclaim(asf_path, amc_paths):
            asf = pa.loadASF(str(asf_path), verbose=False)
            for p in amc_paths:
                pa.loadAMC(asf, str(p))
        readers["pyacclaim"] = acclaim
    except Exception as err:  # noqa: BLE001 - report and go on
        skip["pyacclaim"] = repr(err)
    if os.environ.get("FAIRMOTION_PATH"):
        sys.path.insert(0, os.environ["FAIRMOTION_PATH"])
    try:
        from fairmotion.data import asfamc as fm

        def fairmotion(asf_path, amc_paths):
            for p in amc_paths:
                fm.load(str(asf_path), motion=str(p))
        readers["fairmotion"] = fairmotion
    except Exception as err:  # noqa: BLE001
        skip["fairmotion"] = f"does not import: {err!r}"
    return readers


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--amc-step", type=int, default=2, help="use every k-th HDM05 clip (same files for all)")
    ap.add_argument("--bandai-step", type=int, default=10, help="use every k-th Bandai take (same files for all)")
    args = ap.parse_args(argv)
    data = find_data_dir()
    summary = {}

    bvh_files = sorted((data / "cmu").glob("*/*.bvh"))
    bvh_rates = time_bvh_readers(bvh_files, "CMU", args.repeats)
    peers = {k: v for k, v in bvh_rates.items() if not k.startswith("mocapviz")}
    best_peer = max(peers, key=peers.get) if peers else None
    summary.update(bvh_mb_s=round(bvh_rates["mocapviz"], 2), best_bvh_peer=best_peer,
                   best_bvh_peer_mb_s=round(peers[best_peer], 2) if best_peer else None,
                   bvh_ratio=round(bvh_rates["mocapviz"] / peers[best_peer], 3) if best_peer else None,
                   bvh_with_matrices_ratio=round(bvh_rates["mocapviz+matrices"] / peers[best_peer], 3)
                   if best_peer else None)
    bandai_files = sorted((data / "bandai").glob("*/*.bvh"))[::args.bandai_step]
    if bandai_files:  # 6 channels on every joint, 30 fps: the other BVH shape real files have
        rates = time_bvh_readers(bandai_files, f"Bandai (every {args.bandai_step}th take)", args.repeats)
        summary["bandai_mb_s"] = {k: round(v, 2) for k, v in rates.items()}
        summary["bandai_ratio_vs"] = {k: round(rates["mocapviz"] / v, 2) for k, v in rates.items()
                                      if not k.startswith("mocapviz")}

    # Peers cannot open the clips whose first line has a Latin-1 byte (they decode UTF-8):
    # every reader gets the same UTF-8-clean clips.
    all_amc = sorted((data / "hdm05").glob("*/*.amc"))
    clean = [p for p in all_amc if _is_utf8(p)]
    print(f"AMC: {len(all_amc) - len(clean)} of {len(all_amc)} HDM05 clips are not UTF-8 (peers fail on them)")
    by_actor = {}
    for p in clean[::args.amc_step]:
        by_actor.setdefault(p.parent, []).append(p)
    amc_files = [p for ps in by_actor.values() for p in ps]
    amc_mb = sum(p.stat().st_size for p in amc_files) / 1e6
    print(f"AMC: {len(amc_files)} UTF-8 HDM05 clips (every {args.amc_step}th), {amc_mb:.2f} MB, ASF parse included")
    skip = {}
    amc_rates = {}
    for name, fn in amc_readers(skip).items():
        reps = args.repeats if name.startswith("mocapviz") else 1
        try:
            t = best_time(lambda: [fn(d / f"HDM_{d.name}.asf", ps) for d, ps in by_actor.items()], reps)
        except Exception as err:  # noqa: BLE001
            skip[name] = f"failed: {err!r}"[:200]
            continue
        amc_rates[name] = amc_mb / t
        print(f"  {name:12s} {amc_rates[name]:8.1f} MB/s  ({t:.3f} s)")
    for name, why in skip.items():
        print(f"  {name:12s} skipped: {why}")
    amc_peers = {k: v for k, v in amc_rates.items() if not k.startswith("mocapviz")}
    best_amc = max(amc_peers, key=amc_peers.get) if amc_peers else None
    summary.update(amc_mb_s=round(amc_rates["mocapviz"], 2),
                   amc_with_matrices_mb_s=round(amc_rates["mocapviz+matrices"], 2), best_amc_peer=best_amc,
                   amc_ratio=round(amc_rates["mocapviz"] / amc_peers[best_amc], 2) if best_amc else None)

    with tempfile.TemporaryDirectory() as cache_dir:
        t0 = time.perf_counter()
        cold = build_catalog(data, cache=True, cache_dir=cache_dir)
        t1 = time.perf_counter()
        warm = build_catalog(data, cache=True, cache_dir=cache_dir)
        t2 = time.perf_counter()
    print(f"catalog: {len(cold)} clips; cold {t1 - t0:.3f} s ({cold.attrs.get('cache')}), "
          f"from cache {t2 - t1:.3f} s ({warm.attrs.get('cache')})")
    summary.update(catalog_cold_s=round(t1 - t0, 3), catalog_cached_s=round(t2 - t1, 3))
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
