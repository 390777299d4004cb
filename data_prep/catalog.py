"""One catalog of the real clips (HDM05, CMU, H3.6M, Bandai) and a loader into Motion.

Every row: source, subject, clip, motion_type (the source's own label), path, skeleton_path
(the ASF for HDM05), fps, frames (usable frames: CMU's inserted T-pose frame 0 excluded),
duration_s (``(frames - 1) / fps``, the same convention as ``Motion.duration``), first_frame
(index of the first usable frame in the file), description, and three more columns:

- ``segment``: which part of the original recording the file holds. CMU: from ``index.tsv``
  (``full`` = whole trial; ``window`` = the T-pose frame 0 plus a contiguous run from the middle
  of the trial, so there is a jump between frame 0 and frame 1, which ``first_frame = 1`` skips).
  HDM05 and H3.6M files are whole clips: ``full``.
- ``trainable``: whole clips (``segment`` full/prefix) always; excerpts (``window``) only when
  their usable part lasts at least :data:`MIN_WINDOW_SECONDS`. False exactly for the four 0.35 s
  CMU jump/kick excerpts, usable for skeletons and poses, too short for training windows. (Whole
  HDM05 clips can be short, e.g. a single hop of 0.46 s, but each is a complete action.)
- ``split``: the source's own train/test split where it defines one (HDM05: actors mm and tr
  are test; H3.6M: S5 is test), empty for CMU and Bandai.
- ``style``: Bandai's style label (``normal``, ``elderly``, ...), empty for the other sources.

Bandai rows: ``subject`` is ``bandai1``/``bandai2`` (its dataset-1 and dataset-2: the actor of a
take is not recorded and all share one proportion-aligned skeleton), ``motion_type`` is the
coarse type of :data:`BANDAI_MOTION_TYPES` and ``description`` the upstream content label.
Bandai is opt-in (``build_catalog(sources=SOURCES)``, or the CLI's ``catalog``): the default
:data:`DEFAULT_SOURCES` keep the datasets built from the catalog as they were.

``build_catalog`` caches its result under ``cache/`` at the repository root, keyed by a hash of
the data files (relative path, size, mtime), :data:`SCHEMA_VERSION` and this module's source.
"""

from __future__ import annotations

import csv
import hashlib
import re
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from data_prep.sources import REPO_ROOT, SOURCE_LENGTH_UNITS, SOURCES, find_data_dir
from mocapviz.atomic import atomic_path

if TYPE_CHECKING:
    from mocapviz.motion import Motion

COLUMNS = ["source", "subject", "clip", "motion_type", "path", "skeleton_path", "fps", "frames",
           "duration_s", "first_frame", "description", "segment", "trainable", "split", "style"]
# Bump when the columns or the way a row is computed change: old cache files are then ignored.
SCHEMA_VERSION = 3
DEFAULT_SOURCES = ("hdm05", "cmu", "h36m")
# Bandai's content labels -> motion types (walks and turns kept apart; gestures grouped).
BANDAI_MOTION_TYPES = {
    "walk": "walk", "walk-turn-left": "walk-turn-left", "walk-turn-right": "walk-turn-right",
    "run": "run", "dash": "dash", "walk-back": "walk-back",
    "walk-left": "side-step-left", "walk-right": "side-step-right",
    **{f"{a}-{s}": "hand-action" for a in ("wave", "raise-up") for s in ("both-hands", "left-hand", "right-hand")},
    **dict.fromkeys(("bow", "bye", "byebye", "call", "guide", "respond"), "gesture"),
    **dict.fromkeys(("kick", "punch", "slash"), "fighting"),
    "dance-short": "dance",
}
# Shortest excerpt (segment = window) that can give training windows; whole clips always can.
MIN_WINDOW_SECONDS = 1.0
CACHE_DIR = REPO_ROOT / "cache"

HDM05_TEST_ACTORS = ("mm", "tr")
H36M_TEST_SUBJECTS = ("S5",)
H36M_SUBJECTS = ("S1", "S5", "S6", "S7", "S8", "S9", "S11")
H36M_ACTIONS = ("walking", "eating", "smoking", "discussion")
# Files of the (subject, action, subaction) grid absent from the shared copy (h36m/README.md).
H36M_MISSING = frozenset(
    [("S5", "discussion", k) for k in (1, 2)]
    + [(s, a, k) for s in ("S7", "S9") for a in ("discussion", "smoking") for k in (1, 2)]
    + [("S8", "smoking", k) for k in (1, 2)])

_HDM05_NAME = re.compile(r"HDM_(?P<subject>[a-z]+)_(?P<cls>.+)_(?P<num>\d+)_(?P<fps>\d+)\.amc$")


def _count_amc_frames(path: Path) -> int:
    with open(path, "rb") as f:
        return sum(1 for line in f if line.strip().isdigit())


def _bvh_frames(path: Path) -> int:
    with open(path, "rb") as f:
        for line in f:
            if line.strip().lower().startswith(b"frames:"):
                return int(line.split(b":")[1])
    raise ValueError(f"{path}: no Frames line")


def _row(**kw) -> dict:
    kw.setdefault("style", "")
    kw["duration_s"] = (kw["frames"] - 1) / kw["fps"]
    kw["trainable"] = bool(kw["segment"] != "window" or kw["duration_s"] >= MIN_WINDOW_SECONDS)
    return kw


def hdm05_rows(root: Path) -> list[dict]:
    rows = []
    for amc in sorted(root.glob("*/*.amc")):
        m = _HDM05_NAME.match(amc.name)
        if not m:
            continue
        rows.append(_row(source="hdm05", subject=m["subject"], clip=amc.stem, motion_type=m["cls"],
                         path=str(amc), skeleton_path=str(amc.parent / f"HDM_{m['subject']}.asf"),
                         fps=float(m["fps"]), frames=_count_amc_frames(amc), first_frame=0,
                         description=m["cls"], segment="full",
                         split="test" if m["subject"] in HDM05_TEST_ACTORS else "train"))
    return rows


def cmu_rows(root: Path) -> list[dict]:
    """Rows from ``cmu/index.tsv``; frame 0 of every file (Hahne's T-pose) is not usable."""
    rows = []
    with open(root / "index.tsv", newline="", encoding="utf-8") as f:
        for rec in csv.DictReader(f, delimiter="\t"):
            path = root / rec["clip"].split("_")[0] / f"{rec['clip']}.bvh"
            if not path.is_file():
                warnings.warn(f"{path} is listed in {root / 'index.tsv'} but missing; skipped")
                continue
            frames = _bvh_frames(path) - 1  # frame 0 is the T-pose Hahne's conversion inserts
            rows.append(_row(source="cmu", subject=f"cmu{int(rec['subject']):02d}", clip=rec["clip"],
                             motion_type=rec["motion_type"], path=str(path), skeleton_path="",
                             fps=120.0, frames=frames, first_frame=1, description=rec["description"],
                             segment=rec.get("segment") or "full", split=""))
    return rows


def h36m_rows(root: Path) -> list[dict]:
    rows = []
    for txt in sorted(root.glob("S*/*.txt")):
        with open(txt, "rb") as f:
            frames = sum(1 for line in f if line.strip())
        subject = txt.parent.name
        rows.append(_row(source="h36m", subject=subject, clip=f"{subject}_{txt.stem}",
                         motion_type=txt.stem.rsplit("_", 1)[0], path=str(txt), skeleton_path="",
                         fps=50.0, frames=frames, first_frame=0, description=txt.stem, segment="full",
                         split="test" if subject in H36M_TEST_SUBJECTS else "train"))
    return rows


def bandai_rows(root: Path) -> list[dict]:
    """Rows from ``bandai/index.tsv`` (content, style, take); frames from each file's header."""
    rows = []
    with open(root / "index.tsv", newline="", encoding="utf-8") as f:
        for rec in csv.DictReader(f, delimiter="\t"):
            path = root / rec["file"]
            if not path.is_file():
                warnings.warn(f"{path} is listed in {root / 'index.tsv'} but missing; skipped")
                continue
            rows.append(_row(source="bandai", subject="bandai" + rec["dataset"].rsplit("-", 1)[1],
                             clip=path.stem, motion_type=BANDAI_MOTION_TYPES.get(rec["content"], rec["content"]),
                             path=str(path), skeleton_path="", fps=float(rec["fps"]), frames=_bvh_frames(path),
                             first_frame=0, description=rec["content"], segment="full", split="",
                             style=rec["style"]))
    return rows


ROW_BUILDERS = {"hdm05": hdm05_rows, "cmu": cmu_rows, "h36m": h36m_rows, "bandai": bandai_rows}


def data_files(root: Path, sources=SOURCES) -> list[Path]:
    """Every file under the ``sources`` folders of ``root``, sorted (what the cache key covers)."""
    out = []
    for name in sources:
        if (root / name).is_dir():
            out += [p for p in (root / name).rglob("*") if p.is_file()]
    return sorted(out)


def cache_key(root: Path, sources=DEFAULT_SOURCES) -> str:
    """Hash of the schema version, the sources, this module's code, the data folder and every
    data file's relative path, size and mtime."""
    h = hashlib.sha256(f"schema={SCHEMA_VERSION}\nroot={Path(root).resolve()}\n"
                       f"sources={','.join(sources)}\n".encode())
    h.update(Path(__file__).read_bytes())
    for p in data_files(root, sources):
        st = p.stat()
        h.update(f"{p.relative_to(root).as_posix()}\t{st.st_size}\t{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:20]


def _scan(root: Path, sources=DEFAULT_SOURCES) -> pd.DataFrame:
    rows = []
    for name in sources:
        if (root / name).is_dir():
            rows += ROW_BUILDERS[name](root / name)
    df = pd.DataFrame(rows, columns=COLUMNS)
    return df.astype({"fps": float, "frames": int, "duration_s": float, "first_frame": int,
                      "trainable": bool})


def _write_atomic_pickle(df: pd.DataFrame, path: Path) -> None:
    with atomic_path(path) as tmp:
        df.to_pickle(tmp)


def _prune(cache_dir: Path, keep: Path, n_keep: int = 8) -> None:
    """Drop all but the ``n_keep`` newest catalog caches (other checkouts or data folders may
    share the folder, so a few are kept)."""
    old = sorted((p for p in cache_dir.glob("catalog-*.pkl") if p != keep),
                 key=_safe_mtime, reverse=True)
    for p in old[n_keep - 1:]:
        p.unlink(missing_ok=True)


def _safe_mtime(p: Path) -> float:
    try:
        return p.stat().st_mtime
    except OSError:  # removed meanwhile by another process
        return 0.0


def build_catalog(data_dir: str | Path | None = None, cache: bool = True,
                  cache_dir: str | Path | None = None, sources=DEFAULT_SOURCES) -> pd.DataFrame:
    """Catalog of every clip of ``sources`` found under the data folder (see
    :func:`find_data_dir`); pass ``sources=SOURCES`` to include Bandai.

    With ``cache`` (default) the table is read from ``cache_dir`` (default ``<repo>/cache``)
    when the data files are unchanged, and written there (atomically) otherwise.
    ``df.attrs['cache']`` says what happened: ``'hit'``, ``'miss'`` or ``'off'``.
    """
    root = find_data_dir(data_dir)
    unknown = set(sources) - set(SOURCES)
    if unknown:
        raise ValueError(f"unknown sources {sorted(unknown)}; choose from {SOURCES}")
    if not cache:
        df = _scan(root, sources)
        df.attrs.update(cache="off", data_dir=str(root))
        return df
    cache_dir = Path(cache_dir) if cache_dir is not None else CACHE_DIR
    path = cache_dir / f"catalog-{cache_key(root, sources)}.pkl"
    if path.is_file():
        try:
            df = pd.read_pickle(path)
            if list(df.columns) == COLUMNS:
                df.attrs.update(cache="hit", cache_path=str(path), data_dir=str(root))
                return df
        except Exception as e:  # unreadable or truncated: rebuild below
            warnings.warn(f"ignoring unreadable catalog cache {path}: {e}")
    df = _scan(root, sources)
    try:
        _write_atomic_pickle(df, path)
        _prune(cache_dir, keep=path)
    except OSError as e:
        warnings.warn(f"could not write the catalog cache {path}: {e}")
    df.attrs.update(cache="miss", cache_path=str(path), data_dir=str(root))
    return df


def h36m_missing(catalog: pd.DataFrame) -> set[tuple[str, str, int]]:
    """(subject, action, subaction) of the standard H3.6M grid absent from ``catalog``."""
    have = {(r.subject, r.motion_type, int(r.description.rsplit("_", 1)[1]))
            for r in catalog[catalog.source == "h36m"].itertuples()}
    grid = {(s, a, k) for s in H36M_SUBJECTS for a in H36M_ACTIONS for k in (1, 2)}
    return grid - have


def summary_table(catalog: pd.DataFrame, trainable_only: bool = False) -> pd.DataFrame:
    """Subjects x motion types: clips, frames and seconds.

    Rows are indexed by (source, subject); columns are a MultiIndex (motion_type, quantity)
    with quantity in clips / frames / seconds (sums of ``frames`` and ``duration_s``), plus a
    ``total`` motion type. Motion types a subject lacks are 0.
    """
    df = catalog[catalog.trainable] if trainable_only else catalog
    g = df.groupby(["source", "subject", "motion_type"], sort=False).agg(
        clips=("clip", "size"), frames=("frames", "sum"), seconds=("duration_s", "sum"))
    table = g.unstack("motion_type", fill_value=0).swaplevel(0, 1, axis=1)
    order = list(dict.fromkeys(df.motion_type))
    table = table.reindex(columns=pd.MultiIndex.from_product([order, ["clips", "frames", "seconds"]]),
                          fill_value=0)
    tot = df.groupby(["source", "subject"], sort=False).agg(
        clips=("clip", "size"), frames=("frames", "sum"), seconds=("duration_s", "sum"))
    for q in ("clips", "frames", "seconds"):
        table[("total", q)] = tot[q]
    def natural(key):
        src, subj = key
        digits = re.sub(r"\D", "", subj)
        return (SOURCES.index(src) if src in SOURCES else len(SOURCES), int(digits or -1), subj)

    rows = pd.MultiIndex.from_tuples(sorted(set(zip(df.source, df.subject)), key=natural),
                                     names=["source", "subject"])
    table = table.reindex(rows)
    table.columns.names = ["motion_type", "quantity"]
    return table.astype({c: int for c in table.columns if c[1] != "seconds"})


_ASF_CACHE: dict[str, object] = {}


def load_motion(row) -> Motion:
    """Load a catalog row as a Motion: metres, Y up, usable frames only.

    HDM05 and CMU skeletons come out with the same 31 joint names (the CMU BVH names), so
    that the topology maps of :mod:`mocapviz.skeleton` apply to both. Bandai's reference root
    is folded into ``Hips`` and its joints renamed to the CCNet names they map to
    (:func:`mocapviz.skeleton.map_to_ccnet25`; ``meta['joint_map']``); its joints' position
    channels, which repeat their OFFSETs to < 1e-6 m, are dropped (:meth:`Motion.rigid`).
    """
    # imported here so that scanning the catalog (python -m data_prep catalog) needs no torch
    from mocapviz.io.asfamc import read_amc, read_asf
    from mocapviz.io.bvh import read_bvh
    from mocapviz.io.h36m import read_h36m
    from mocapviz.skeleton import ASF_TO_VICON_BVH, map_to_ccnet25

    row = dict(row)
    if row["source"] == "hdm05":
        asf = _ASF_CACHE.get(row["skeleton_path"])
        if asf is None:
            asf = _ASF_CACHE[row["skeleton_path"]] = read_asf(row["skeleton_path"])
        motion = read_amc(row["path"], asf, fps=row["fps"])
        motion.skeleton = motion.skeleton.renamed(ASF_TO_VICON_BVH)
    elif row["source"] == "cmu":
        motion = read_bvh(row["path"], length_unit=SOURCE_LENGTH_UNITS["cmu"])
    elif row["source"] == "h36m":
        motion = read_h36m(row["path"])
    elif row["source"] == "bandai":
        # fold_root, not drop_static_root: 4 takes move their reference root (folding is exact)
        motion = read_bvh(row["path"], length_unit=SOURCE_LENGTH_UNITS["bandai"]).fold_root().rigid(1e-6)
        joint_map = map_to_ccnet25(motion.skeleton.names)
        motion.skeleton = motion.skeleton.renamed(joint_map)
        motion.meta["joint_map"] = joint_map
    else:
        raise ValueError(f"unknown source {row['source']!r}")
    motion = motion[int(row["first_frame"]):]
    motion.meta.update(source_dataset=row["source"], subject=row["subject"], clip=row["clip"],
                       motion_type=row["motion_type"], style=row.get("style", ""))
    motion.name = row["clip"]
    return motion
