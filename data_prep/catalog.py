"""One catalog of the real clips (HDM05, CMU, H3.6M) and a loader into Motion.

Every row: source, subject, clip, motion_type (the source's own label), path, skeleton_path
(the ASF for HDM05), fps, frames (usable frames: CMU's inserted T-pose frame 0 excluded),
duration_s, first_frame (index of the first usable frame in the file).
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pandas as pd

from data_prep.sources import find_data_dir
from mocapviz.io._text import LENGTH_UNITS
from mocapviz.io.asfamc import read_amc, read_asf
from mocapviz.io.bvh import read_bvh
from mocapviz.io.h36m import read_h36m
from mocapviz.motion import Motion
from mocapviz.skeleton import ASF_TO_VICON_BVH

COLUMNS = ["source", "subject", "clip", "motion_type", "path", "skeleton_path", "fps", "frames",
           "duration_s", "first_frame", "description"]
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


def hdm05_rows(root: Path) -> list[dict]:
    rows = []
    for amc in sorted(root.glob("*/*.amc")):
        m = _HDM05_NAME.match(amc.name)
        if not m:
            continue
        fps = float(m["fps"])
        frames = _count_amc_frames(amc)
        rows.append(dict(source="hdm05", subject=m["subject"], clip=amc.stem, motion_type=m["cls"],
                         path=str(amc), skeleton_path=str(amc.parent / f"HDM_{m['subject']}.asf"), fps=fps,
                         frames=frames, duration_s=(frames - 1) / fps, first_frame=0, description=m["cls"]))
    return rows


def cmu_rows(root: Path) -> list[dict]:
    rows = []
    with open(root / "index.tsv", newline="") as f:
        for rec in csv.DictReader(f, delimiter="\t"):
            path = root / rec["clip"].split("_")[0] / f"{rec['clip']}.bvh"
            frames = _bvh_frames(path) - 1  # frame 0 is the T-pose Hahne's conversion inserts
            rows.append(dict(source="cmu", subject=f"cmu{int(rec['subject']):02d}", clip=rec["clip"],
                             motion_type=rec["motion_type"], path=str(path), skeleton_path="", fps=120.0,
                             frames=frames, duration_s=(frames - 1) / 120.0, first_frame=1,
                             description=rec["description"]))
    return rows


def h36m_rows(root: Path) -> list[dict]:
    rows = []
    for txt in sorted(root.glob("S*/*.txt")):
        with open(txt, "rb") as f:
            frames = sum(1 for line in f if line.strip())
        action = txt.stem.rsplit("_", 1)[0]
        rows.append(dict(source="h36m", subject=txt.parent.name, clip=f"{txt.parent.name}_{txt.stem}",
                         motion_type=action, path=str(txt), skeleton_path="", fps=50.0, frames=frames,
                         duration_s=(frames - 1) / 50.0, first_frame=0, description=txt.stem))
    return rows


def build_catalog(data_dir: str | Path | None = None) -> pd.DataFrame:
    """Catalog of every clip found under the data folder (see :func:`find_data_dir`)."""
    root = find_data_dir(data_dir)
    rows = []
    for name, fn in (("hdm05", hdm05_rows), ("cmu", cmu_rows), ("h36m", h36m_rows)):
        if (root / name).is_dir():
            rows += fn(root / name)
    return pd.DataFrame(rows, columns=COLUMNS)


_ASF_CACHE: dict[str, object] = {}


def load_motion(row) -> Motion:
    """Load a catalog row as a Motion: metres, Y up, usable frames only.

    HDM05 and CMU skeletons come out with the same 31 joint names (the CMU BVH names), so
    that the topology maps of :mod:`mocapviz.skeleton` apply to both.
    """
    row = dict(row)
    if row["source"] == "hdm05":
        asf = _ASF_CACHE.get(row["skeleton_path"])
        if asf is None:
            asf = _ASF_CACHE[row["skeleton_path"]] = read_asf(row["skeleton_path"])
        motion = read_amc(row["path"], asf, fps=row["fps"])
        motion.skeleton = motion.skeleton.renamed(ASF_TO_VICON_BVH)
    elif row["source"] == "cmu":
        motion = read_bvh(row["path"], length_unit=LENGTH_UNITS["cmu"])
    elif row["source"] == "h36m":
        motion = read_h36m(row["path"])
    else:
        raise ValueError(f"unknown source {row['source']!r}")
    motion = motion[int(row["first_frame"]):]
    motion.meta.update(source_dataset=row["source"], subject=row["subject"], clip=row["clip"],
                       motion_type=row["motion_type"])
    motion.name = row["clip"]
    return motion
