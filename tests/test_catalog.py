"""The catalog of the real data: counts from the data READMEs and frame counts checked by hand."""

from __future__ import annotations

import csv
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from data_prep import catalog as cat_mod
from data_prep.catalog import (COLUMNS, H36M_MISSING, build_catalog, cache_key, h36m_missing,
                               summary_table)
from data_prep.sources import REPO_ROOT, DataNotFoundError, find_data_dir

try:
    DATA = find_data_dir()
except DataNotFoundError as e:  # users without the data: nothing real to test
    pytest.skip(str(e), allow_module_level=True)

HDM05_CLASSES = {  # hdm05/README.md
    "hopBothLegs1hops": 36, "jogLeftCircle4StepsRstart": 17, "kickLFront1Reps": 29,
    "sneak2StepsLStart": 15, "squat1Reps": 52, "depositFloorR": 32, "grabHighR": 29,
    "elbowToKnee1RepsLelbowStart": 27, "lieDownFloor": 20, "rotateArmsBothBackward1Reps": 16,
    "throwBasketball": 14}


@pytest.fixture(scope="module")
def catalog():
    return build_catalog(DATA, cache=False)


def test_columns_and_sources(catalog):
    assert list(catalog.columns) == COLUMNS
    assert catalog.groupby("source").size().to_dict() == {"hdm05": 287, "cmu": 15, "h36m": 44}
    assert catalog["clip"].is_unique
    assert all(Path(p).is_file() for p in catalog.path)


def test_hdm05_counts(catalog):
    h = catalog[catalog.source == "hdm05"]
    assert sorted(h.subject.unique()) == ["bd", "bk", "dg", "mm", "tr"]
    assert h.groupby("motion_type").size().to_dict() == HDM05_CLASSES
    assert set(h[h.split == "test"].subject) == {"mm", "tr"}
    assert set(h[h.split == "train"].subject) == {"bd", "bk", "dg"}
    assert (h.fps == 120).all() and (h.first_frame == 0).all() and (h.segment == "full").all()
    assert h.trainable.all()  # whole clips, even a 0.46 s single hop
    assert all(Path(p).is_file() for p in h.skeleton_path)
    # "about 9.9 minutes": 70996 frames at 120 fps
    assert h.frames.sum() == 70996
    assert h.frames.sum() / 120 / 60 == pytest.approx(9.86, abs=0.01)


def test_cmu_matches_index_and_readme(catalog):
    c = catalog[catalog.source == "cmu"].set_index("clip")
    assert len(c) == 15 and c.subject.nunique() == 14
    assert c.groupby("motion_type").size().to_dict() == {"walk": 8, "run": 3, "jump": 2, "kick": 2}
    with open(DATA / "cmu" / "index.tsv", newline="") as f:
        index = {r["clip"]: r for r in csv.DictReader(f, delimiter="\t")}
    assert set(index) == set(c.index)
    for clip, r in index.items():
        assert c.loc[clip, "segment"] == r["segment"]
        assert c.loc[clip, "frames"] == int(r["motion_frames_after_tpose"]) == int(r["frames_kept"]) - 1
        assert c.loc[clip, "description"] == r["description"]
    assert set(c.index[c.segment == "window"]) == {"36_02", "69_06", "91_02", "141_19",
                                                    "16_07", "49_03", "143_24", "144_05"}
    assert (c.first_frame == 1).all()  # frame 0 is the inserted T-pose, windows jump after it
    # the 0.35 s jump/kick excerpts, and only they, are too short for training windows
    assert set(c.index[~c.trainable]) == {"16_07", "49_03", "143_24", "144_05"}
    assert (c.split == "").all()


def _bvh_data_lines(path) -> tuple[int, int]:
    """(Frames: value, number of frame lines after 'Frame Time'), counted independently."""
    lines = Path(path).read_bytes().split(b"\n")
    declared = next(int(l.split(b":")[1]) for l in lines if l.lower().startswith(b"frames:"))
    start = next(i for i, l in enumerate(lines) if l.lower().startswith(b"frame time")) + 1
    return declared, sum(1 for l in lines[start:] if l.strip())


@pytest.mark.parametrize("clip,frames", [("07_01", 316), ("16_07", 42), ("36_02", 341),
                                         ("144_05", 41), ("127_03", 332)])
def test_cmu_frames_by_hand(catalog, clip, frames):
    row = catalog.set_index("clip").loc[clip]
    declared, counted = _bvh_data_lines(row.path)
    assert declared == counted == frames + 1  # file frames include the T-pose
    assert row.frames == frames
    assert row.duration_s == pytest.approx((frames - 1) / 120)


@pytest.mark.parametrize("clip,frames", [("HDM_bd_squat1Reps_001_120", 140),
                                         ("HDM_tr_throwBasketball_012_120", 721),
                                         ("HDM_bk_hopBothLegs1hops_020_120", 56)])
def test_hdm05_frames_by_hand(catalog, clip, frames):
    row = catalog.set_index("clip").loc[clip]
    numbers = [int(l) for l in Path(row.path).read_bytes().split(b"\n") if re.fullmatch(rb"\d+\s*", l)]
    assert numbers == list(range(1, frames + 1))
    assert row.frames == frames


def test_h36m_subjects_and_gaps(catalog):
    h = catalog[catalog.source == "h36m"]
    assert sorted(h.subject.unique(), key=lambda s: int(s[1:])) == ["S1", "S5", "S6", "S7", "S8", "S9", "S11"]
    assert h36m_missing(catalog) == set(H36M_MISSING)
    assert len(H36M_MISSING) == 12 and len(h) == 7 * 4 * 2 - 12
    assert set(h[h.split == "test"].subject) == {"S5"}
    by_clip = h.set_index("clip").frames
    assert by_clip["S1_walking_1"] == 3476 and by_clip["S5_walking_1"] == 3000  # wc -l
    assert (h.fps == 50).all() and h.trainable.all()


def test_summary_table(catalog):
    t = summary_table(catalog)
    assert len(t) == 5 + 14 + 7
    assert t[("total", "clips")].sum() == len(catalog)
    assert t[("total", "frames")].sum() == catalog.frames.sum()
    assert t.loc[("cmu", "cmu16"), ("walk", "clips")] == 1 and t.loc[("cmu", "cmu16"), ("jump", "frames")] == 42
    assert t.loc[("hdm05", "bd"), ("squat1Reps", "clips")] == 12
    assert t.loc[("h36m", "S7"), ("smoking", "clips")] == 0
    assert t.xs("seconds", axis=1, level="quantity")["total"].sum() == pytest.approx(catalog.duration_s.sum())
    assert summary_table(catalog, trainable_only=True)[("total", "clips")].sum() == len(catalog) - 4


def test_load_motion_skips_tpose_of_window(catalog):
    row = catalog.set_index("clip").loc["36_02"]
    motion = cat_mod.load_motion({**row.to_dict(), "clip": "36_02"})
    assert motion.n_frames == row.frames == 341
    lines = Path(row.path).read_text().split("\n")
    start = next(i for i, l in enumerate(lines) if l.startswith("Frame Time")) + 1
    frame1 = [float(v) for v in lines[start + 1].split()]  # first frame after the T-pose
    scale = motion.root_positions[0, 1] / frame1[1]
    assert motion.root_positions[0] == pytest.approx([frame1[0] * scale, frame1[1] * scale, frame1[2] * scale])
    assert scale == pytest.approx(0.0254 / 0.45, rel=1e-6)  # CMU units: 1/0.45 inch


# --- cache ------------------------------------------------------------------------------------

def _small_copy(dst: Path, amcs: int = 3) -> Path:
    """Symlinks to a small part of the real data: one HDM05 actor and two H3.6M files."""
    (dst / "hdm05" / "bd").mkdir(parents=True)
    src = DATA / "hdm05" / "bd"
    for f in [src / "HDM_bd.asf"] + sorted(src.glob("*.amc"))[:amcs]:
        (dst / "hdm05" / "bd" / f.name).symlink_to(f)
    (dst / "h36m" / "S1").mkdir(parents=True)
    for name in ("walking_1.txt", "eating_2.txt"):
        (dst / "h36m" / "S1" / name).symlink_to(DATA / "h36m" / "S1" / name)
    return dst


def test_cache_dir_is_git_ignored_repo_cache():
    assert cat_mod.CACHE_DIR == REPO_ROOT / "cache"
    assert "cache/" in (REPO_ROOT / ".gitignore").read_text().split()


def test_cache_hit_and_invalidation(tmp_path):
    data, cache = _small_copy(tmp_path / "data"), tmp_path / "cache"
    first = build_catalog(data, cache_dir=cache)
    assert first.attrs["cache"] == "miss" and len(first) == 5
    second = build_catalog(data, cache_dir=cache)
    assert second.attrs["cache"] == "hit"
    pd.testing.assert_frame_equal(first, second)
    assert [p.name for p in cache.iterdir()] == [Path(first.attrs["cache_path"]).name]  # no temp files

    extra = sorted((DATA / "hdm05" / "bd").glob("*.amc"))[3]
    (data / "hdm05" / "bd" / extra.name).symlink_to(extra)  # the file list changed
    third = build_catalog(data, cache_dir=cache)
    assert third.attrs["cache"] == "miss" and len(third) == 6 and extra.stem in set(third["clip"])

    (data / "hdm05" / "bd" / extra.name).unlink()
    (data / "h36m" / "S1" / "eating_2.txt").unlink()  # same name, another real file: size changes
    (data / "h36m" / "S1" / "eating_2.txt").symlink_to(DATA / "h36m" / "S1" / "eating_1.txt")
    fourth = build_catalog(data, cache_dir=cache)
    assert fourth.attrs["cache"] == "miss"
    eating_1_lines = (DATA / "h36m" / "S1" / "eating_1.txt").read_bytes().count(b"\n")
    assert fourth.set_index("clip").frames["S1_eating_2"] == eating_1_lines
    assert first.set_index("clip").frames["S1_eating_2"] != eating_1_lines


def test_cache_key_depends_on_schema_and_survives_corrupt_cache(tmp_path, monkeypatch):
    data, cache = _small_copy(tmp_path / "data", amcs=1), tmp_path / "cache"
    key = cache_key(data)
    monkeypatch.setattr(cat_mod, "SCHEMA_VERSION", cat_mod.SCHEMA_VERSION + 1)
    assert cache_key(data) != key
    df = build_catalog(data, cache_dir=cache)
    Path(df.attrs["cache_path"]).write_bytes(b"truncated")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        again = build_catalog(data, cache_dir=cache)
    assert again.attrs["cache"] == "miss" and any("unreadable" in str(x.message) for x in w)
    pd.testing.assert_frame_equal(df, again)
    assert build_catalog(data, cache_dir=cache).attrs["cache"] == "hit"


def test_cache_off_writes_nothing(tmp_path):
    data = _small_copy(tmp_path / "data", amcs=1)
    df = build_catalog(data, cache=False, cache_dir=tmp_path / "cache")
    assert df.attrs["cache"] == "off" and not (tmp_path / "cache").exists()


@pytest.fixture(scope="module")
def with_bandai():
    if not (DATA / "bandai").is_dir():
        pytest.skip("no bandai folder in the data folder")
    return build_catalog(DATA, cache=False, sources=cat_mod.SOURCES)


def test_bandai_is_opt_in_and_matches_its_readme_and_index(catalog, with_bandai):
    assert "bandai" not in set(catalog.source)  # the default sources keep the datasets unchanged
    b = with_bandai[with_bandai.source == "bandai"]
    assert len(b) == 1256 and b["clip"].is_unique
    assert b.groupby("subject").size().to_dict() == {"bandai1": 174, "bandai2": 1082}
    assert (b.fps == 30).all() and (b.first_frame == 0).all() and (b.split == "").all()
    assert b.duration_s.sum() / 60 == pytest.approx(110, abs=1)  # "about 110 minutes"
    minutes = (b.frames / b.fps).groupby(b.motion_type).sum() / 60  # the README counts frames / fps
    # README: walk 28.2, turns 20.1 / 20.5, run 18.7, walk-back 2.1, side steps 2.8, dash 0.7.
    # (It also says hand actions 9.9; the 120 files hold 17,558 frames = 9.75 min, as index.tsv says.)
    readme = {"walk": 28.2, "walk-turn-left": 20.1, "walk-turn-right": 20.5, "run": 18.7, "walk-back": 2.1,
              "dash": 0.7}
    assert b[b.motion_type == "hand-action"].frames.sum() == 17558
    for t, m in readme.items():
        assert minutes[t] == pytest.approx(m, abs=0.1), t
    assert minutes["side-step-left"] + minutes["side-step-right"] == pytest.approx(2.8, abs=0.1)
    with open(DATA / "bandai" / "index.tsv", newline="") as f:
        index = {Path(r["file"]).stem: r for r in csv.DictReader(f, delimiter="\t")}
    for r in b.itertuples():
        rec = index[r.clip]
        assert (r.description, r.style, r.frames) == (rec["content"], rec["style"], int(rec["frames"]))
    assert set(b[b.subject == "bandai2"]["style"]) == {
        "active", "elderly", "exhausted", "feminine", "masculine", "normal", "youthful"}
    assert b.set_index("clip").motion_type["dataset-1_walk-left_happy_001"] == "side-step-left"


def test_bandai_load_motion_folds_the_root_and_maps_the_names(with_bandai):
    from data_prep.catalog import load_motion
    row = with_bandai[with_bandai["clip"] == "dataset-2_walk_normal_001"].iloc[0]
    m = load_motion(row)
    assert m.skeleton.names[:4] == ("Hips", "Spine", "Spine1", "Neck") and "LeftUpLeg" in m.skeleton.names
    assert m.meta["joint_map"]["UpperLeg_L"] == "LeftUpLeg" and m.meta["style"] == "normal"
    assert m.translations == {} and m.n_frames == row.frames
    travel = np.linalg.norm(np.diff(m.root_positions[:, [0, 2]], axis=0), axis=1).sum()
    assert travel > 2.0  # the walk goes somewhere (it stayed at 0.00 m before folding)
