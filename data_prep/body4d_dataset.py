"""Build and cache the 4D body-motion dataset (multi-frame 4D motion paper, §3.1, §4.1-4.2).

Real mocap (CMU walk/run BVH, HDM05 jog/sneak ASF/AMC, Bandai walks, turning walks, runs,
walk-back BVH) -> per subject, anny's body shape fitted to the subject's bone lengths under a
shape prior (:mod:`mocapviz.bodies.shape_fit`; recorded genders in
:data:`data_prep.body4d_splits.SUBJECT_GENDER`) -> every clip retargeted onto that body ->
single gait cycles found by DTW on the hip rotation curves (flexion and abduction of both
thighs) against real references of forward and backward walking
(:mod:`mocapviz.features.cycles`) -> cut-off, misshapen and half cycles rejected and listed
(``ds.rejected``) -> each cycle as chi = [Theta, Gamma, Phi] (100 time-stamped frames) with
its body's beta. Meshes are not stored: mesh a cycle on demand with
:meth:`mocapviz.datasets.body4d.Body4DDataset.mesh`.

Bandai is re-based onto a T-pose rest with world-aligned joint frames first (as for CCNet,
:func:`data_prep.ccnet_dataset.bandai_alignment`), so that its hip curves and rest alignment
mean what they mean for CMU and HDM05. Its ``walk-left``/``walk-right`` takes (the catalog's
``side-step-left/right``) are forward walks towards the left/right, not side steps: the pelvis
faces where it goes (:func:`heading_offset`, notebook 10), so they are typed ``walk``. The
shared data holds no side-step clip, hence no side-step reference.

Bodies, split and scales: :mod:`data_prep.body4d_splits` (Bandai takes spread over drawn
bodies; held-out subjects HDM05 tr, CMU 35 and 09; held-out Bandai takes on their own body and
on held-out bodies; validation takes; Gamma's scale from training cycles only, stored in
``meta['gamma_scale']``). A cycle's ``subject`` is who performed it, its ``body`` whose shape
(beta) it is on.

``python -m data_prep build body4d [--quick]`` or ``python -m data_prep.body4d_dataset``.
Cached under ``cache/body4d/`` keyed by the config, the data files, the code and anny's version.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

import data_prep.body4d_splits as splits
import mocapviz.datasets.body4d as container
from data_prep.cached import load_or_build
from data_prep.catalog import CACHE_DIR, build_catalog, cache_key, load_motion
from data_prep.sources import find_data_dir
from mocapviz.datasets.body4d import Body4DDataset

DATASET_VERSION = 3  # 3: Bandai takes on drawn bodies, held-out bodies, validation takes
# The cyclic locomotion clips (the catalog's motion_type) and the type names used in the dataset.
MOTION_TYPES = {"walk": "walk", "run": "run", "jogLeftCircle4StepsRstart": "jog",
                "sneak2StepsLStart": "sneak", "walk-turn-left": "turn_left", "walk-turn-right": "turn_right",
                "walk-back": "walk_back", "side-step-left": "walk", "side-step-right": "walk", "dash": "run"}
SOURCES = ("hdm05", "cmu", "bandai")
# Reference cycles (clip, first frame, last frame), each from the left thigh's maximal extension
# to the next (left flexion minima, read off the curves): forward walk CMU 07_01 (1.06 s; its
# mirror is the right-start reference), backward walk Bandai walk-back (active style, 1.17 s).
REFERENCE_CLIP = "07_01"
REFERENCE_FRAMES = (134, 261)
REFERENCES = {"walk": (REFERENCE_CLIP, *REFERENCE_FRAMES),
              "walk_back": ("dataset-1_walk-back_active_001", 79, 114)}
QUICK_SUBJECTS = ("cmu07", "cmu09", "cmu35", "bd", "tr", "bandai1", "bandai2")


@dataclass(frozen=True)
class Body4DConfig:
    subjects: tuple = ()  # empty: every subject with cyclic clips
    clips_per_type: int = 0  # per subject and type; 0 = all
    threshold: float = 12.0  # DTW distance threshold (degrees, see features.cycles)
    n_frames: int = 100
    mirror: bool = False  # add left/right mirrored cycles (flagged) as augmentation
    fit_steps: int = 100
    sources: tuple = SOURCES
    test_sources: tuple = splits.TEST_SOURCES
    test_subjects: tuple = splits.TEST_SUBJECTS
    takes_share: float = splits.TAKES_SHARE  # Bandai takes held out per content
    val_share: float = splits.VAL_SHARE  # Bandai takes kept for validation per content
    seed: int = 0

    def key(self) -> str:
        return json.dumps(dataclasses.asdict(self), sort_keys=True)

    @classmethod
    def quick(cls) -> "Body4DConfig":
        return cls(subjects=QUICK_SUBJECTS, clips_per_type=2)


# ---------------------------------------------------------------------------------- build
def _catalog_rows(config: Body4DConfig, root: Path) -> pd.DataFrame:
    cat = build_catalog(root, sources=config.sources)
    cat = cat[cat["motion_type"].isin(list(MOTION_TYPES)) & cat["source"].isin(config.sources)].copy()
    if config.subjects:
        missing = set(config.subjects) - set(cat["subject"])
        if missing:
            raise ValueError(f"subjects {sorted(missing)} have no cyclic clips in {root}")
        cat = cat[cat["subject"].isin(config.subjects)]
    if config.clips_per_type:
        cat = cat.groupby(["subject", "motion_type"], group_keys=False).head(config.clips_per_type)
    return cat.reset_index(drop=True)


def dataset_hash(config: Body4DConfig, root: Path) -> str:
    import anny

    import mocapviz.bodies as bodies
    import mocapviz.features.cycles as cycles_mod

    h = hashlib.sha256(f"v{DATASET_VERSION}\n{config.key()}\n{cache_key(root, config.sources)}\n"
                       f"anny={anny.__version__}\n".encode())
    for p in sorted(Path(bodies.__file__).parent.glob("*.py")) + [Path(cycles_mod.__file__), Path(container.__file__),
                                                                  Path(splits.__file__), Path(__file__)]:
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def load_clip(row, root: Path):
    """A catalog row as a Motion; Bandai re-based onto a T-pose rest (module docstring)."""
    motion = load_motion(row)
    if row["source"] == "bandai":
        from data_prep.ccnet_dataset import bandai_alignment
        from mocapviz.features.ccnet_joints import rebase_rest

        motion = rebase_rest(motion, bandai_alignment(root))
    return motion


def reference_cycles(root: Path | None = None) -> list:
    """The references of :data:`REFERENCES` (each a left-start cycle and its mirror)."""
    from mocapviz.features.cycles import make_references

    root = find_data_dir(root)
    cat = build_catalog(root, sources=SOURCES)
    out = []
    for kind, (clip, start, end) in REFERENCES.items():
        row = cat[cat["clip"] == clip]
        if row.empty:
            raise ValueError(f"reference clip {clip} is not in the catalog of {root}")
        out.append(make_references(load_clip(row.iloc[0], root), start, end, kind))
    return out


def heading_offset(motion) -> float:
    """Median angle (degrees, -180..180) from the pelvis heading to the ground-plane direction of
    travel: ~0 walking forward, ~180 walking backward, ~+-90 side-stepping."""
    from mocapviz.heading import rotation_heading

    _, glob = motion.global_pose()
    v = np.diff(motion.root_positions[:, [0, 2]], axis=0)
    moving = np.linalg.norm(v, axis=1) * motion.fps > 0.2  # m/s: ignore standing frames
    travel = np.arctan2(v[moving, 0], v[moving, 1])
    diff = np.angle(np.exp(1j * (travel - rotation_heading(glob[1:, 0][moving]))))
    return float(np.degrees(np.median(diff))) if len(diff) else float("nan")


def fit_subject_shapes(cat: pd.DataFrame, body, steps: int = 100, root: Path | None = None):
    """Shape fit of every subject in ``cat`` (skeleton of its first clip), genders held."""
    from mocapviz.bodies.shape_fit import fit_shapes

    skeletons = {s: load_clip(g.iloc[0], root).skeleton for s, g in cat.groupby("subject", sort=True)}
    fixed = {s: {"gender": splits.SUBJECT_GENDER[s]} for s in skeletons if s in splits.SUBJECT_GENDER}
    return fit_shapes(body, skeletons, steps=steps, fixed=fixed), skeletons


def build_dataset(config: Body4DConfig = Body4DConfig(), data_dir=None, cache: bool = True,
                  cache_dir: str | Path | None = None, progress: bool = True) -> Body4DDataset:
    """The dataset for ``config``, from the cache when inputs and code are unchanged."""
    root = find_data_dir(data_dir)
    cache_dir = Path(cache_dir) if cache_dir is not None else CACHE_DIR / "body4d"
    path = cache_dir / f"body4d-{dataset_hash(config, root)}.npz"

    def build() -> Body4DDataset:
        ds = _build(config, root, progress)
        ds.meta["hash"] = path.stem
        return ds

    return load_or_build(path, Body4DDataset.load, build, Body4DDataset.save, cache)


def _retarget_quietly(motion, target):
    """Retarget; Bandai's clavicles move and are held static like every source's (the
    retargeter's warning would repeat for every take)."""
    from mocapviz.bodies.retarget import rest_alignment, retarget

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*is treated as static")
        return retarget(motion, target, rest_alignment(motion.skeleton, target))


def _build(config: Body4DConfig, root: Path, progress: bool) -> Body4DDataset:
    from mocapviz.bodies.anny_model import BETA_LABELS, body_model
    from mocapviz.bodies.representation import (DROPPED_JOINTS, PHI_SCALE, canonicalise, chi_joint_indices,
                                                encode)
    from mocapviz.bodies.retarget import retarget_report
    from mocapviz.features.cycles import find_cycles, half_cycles, resample_uniform, travel

    t0 = time.perf_counter()
    body = body_model()
    cat = _catalog_rows(config, root)
    refs = reference_cycles(root)
    fit, _ = fit_subject_shapes(cat, body, config.fit_steps, root)
    betas = dict(zip(fit.subjects, fit.beta))
    subjects = fit.report()
    subjects["height_m"] = body.measurements(fit.beta)["height"]
    source_of = dict(zip(cat["subject"], cat["source"]))
    subjects["source"] = [source_of[s] for s in subjects["subject"]]
    subjects["gender_recorded"] = [s in splits.SUBJECT_GENDER for s in subjects["subject"]]

    # drawn from the whole catalog, so a config's subset (quick) does not change which takes test
    whole = build_catalog(root, sources=config.sources)
    test_takes = splits.held_out_takes(whole, config.takes_share, config.seed)
    val_takes = splits.validation_takes(whole, config.val_share, config.seed, config.takes_share)

    def held_out(source, subject, clip=""):
        return splits.held_out_set(source, subject, clip, config.test_sources, config.test_subjects, test_takes)

    # a subject is 'test' when none of its cycles trains (Bandai's bodies also have test takes)
    subjects["split"] = ["test" if held_out(r.source, r.subject) else "train" for r in subjects.itertuples()]
    train_bodies = subjects.loc[subjects["split"] == "train", "subject"].tolist()
    test_bodies = [s for s in config.test_subjects if s in betas]
    kept = chi_joint_indices(body.joint_names)
    targets = {s: body.rest_skeleton(betas[s]) for s in betas}
    chis, rows, rejected, clip_rows = [], [], [], []
    for r in tqdm(list(cat.itertuples(index=False)), desc="body4d clips", disable=not progress):
        src = load_clip(r._asdict(), root)
        info = dict(subject=r.subject, source=r.source, clip=r.clip, motion_type=r.motion_type,
                    type=MOTION_TYPES[r.motion_type], style=r.style)
        for body_name, split, test_set in _placements(r, held_out(r.source, r.subject, r.clip), val_takes,
                                                      train_bodies, test_bodies, config.seed):
            variants = [(src, False)] + ([(src.mirrored(), True)] if config.mirror and split == "train" else [])
            for motion, mirrored in variants:
                anny_motion = _retarget_quietly(motion, targets[body_name])
                if not mirrored:
                    clip_rows.append(dict(retarget_report(motion, anny_motion), subject=r.subject, body=body_name,
                                          type=info["type"], source=r.source, heading_offset_deg=heading_offset(src)))
                cycles, bad = find_cycles(motion, refs, threshold=config.threshold)
                for cyc, reason in [(c, "") for c in cycles] + ([] if mirrored else bad):
                    row = dict(info, body=body_name, split=split, test_set=test_set, start=cyc.start, end=cyc.end,
                               side=cyc.side, kind=cyc.kind, dtw_distance=cyc.distance, correlation=cyc.correlation,
                               duration_s=cyc.duration(motion.fps), travel_m=travel(motion, cyc), mirrored=mirrored)
                    if reason:
                        rejected.append(dict(row, reason=reason))
                        continue
                    rot, rootp, times = resample_uniform(anny_motion, cyc.start, cyc.end, config.n_frames)
                    chis.append(encode(rot, rootp, times, kept, np.ones(3)))
                    _, _, yaw, root0 = canonicalise(rot, rootp)
                    rows.append(dict(row, yaw=yaw, root0_y=float(root0[1])))
    n_theta = 6 * len(kept)
    chi = np.stack(chis).astype(np.float32) if chis else np.zeros((0, config.n_frames, n_theta + 4), np.float32)
    cycles = pd.DataFrame(rows)
    # half cycles: a step taken for a stride, judged against the subject's cycles of that type
    half = half_cycles(cycles["travel_m"], cycles["subject"] + "/" + cycles["body"] + "/" + cycles["type"]) \
        if rows else np.zeros(0, bool)
    rejected = pd.concat([pd.DataFrame(rejected), cycles[half].drop(columns=["yaw", "root0_y"]).assign(reason="half")],
                         ignore_index=True)
    chi, cycles = chi[~half], cycles[~half].reset_index(drop=True)
    scale = splits.gamma_scale(chi[..., n_theta:n_theta + 3], (cycles["split"] == "train").values) if rows else np.ones(3)
    chi[..., n_theta:n_theta + 3] /= scale
    beta = np.stack([betas[s] for s in cycles["body"]]).astype(np.float32) if len(cycles) else \
        np.zeros((0, len(BETA_LABELS)), np.float32)
    meta = dict(version=DATASET_VERSION, config=json.loads(config.key()), data_dir=str(root),
                joint_names=list(body.joint_names), chi_joints=[body.joint_names[k] for k in kept],
                dropped_joints=list(DROPPED_JOINTS), beta_labels=list(BETA_LABELS),
                gamma_scale=scale.tolist(), gamma_scale_from="training cycles (split == 'train'), mirrored included",
                phi_scale=PHI_SCALE, n_frames=config.n_frames,
                chi_layout=f"[Theta {n_theta} = {len(kept)} joints x 6D minus identity, Gamma 3, Phi 1]",
                reference=dict(clip=REFERENCE_CLIP, frames=list(REFERENCE_FRAMES)),
                references={k: list(v) for k, v in REFERENCES.items()},
                test_sources=list(config.test_sources), test_subjects=list(config.test_subjects),
                test_takes=sorted(test_takes), validation_takes=sorted(val_takes),
                train_bodies=train_bodies, test_bodies=test_bodies,
                build_seconds=round(time.perf_counter() - t0, 1))
    return Body4DDataset(chi, beta, cycles, subjects, pd.DataFrame(clip_rows), meta, rejected)


def _placements(row, test_set: str, val_takes, train_bodies, test_bodies, seed: int) -> list:
    """(body, split, test_set) of each copy of a clip (see :mod:`data_prep.body4d_splits`)."""
    if row.source not in splits.SPREAD_SOURCES:
        return [(row.subject, "test" if test_set else "train", test_set)]
    if test_set:  # a held-out take: on its own body, and on a held-out one
        out = [(row.subject, "test", test_set)]
        return out + ([(splits.draw_body(row.clip, test_bodies, seed), "test", "held_out_bodies")] if test_bodies else [])
    return [(splits.draw_body(row.clip, train_bodies, seed), "val" if row.clip in val_takes else "train", "")]


def summary(ds: Body4DDataset) -> str:
    clips = ds.clips
    real = ds.cycles[~ds.cycles["mirrored"]]
    return (f"{len(real)} cycles ({(real['split'] == 'test').sum()} test; {len(ds) - len(real)} mirrored copies; "
            f"{int((~ds.rejected['mirrored']).sum()) if len(ds.rejected) else 0} rejected) from {len(clips)} clips of "
            f"{len(ds.subjects)} subjects; shape fit {ds.subjects.err_before_cm.mean():.2f} -> "
            f"{ds.subjects.err_after_cm.mean():.2f} cm; retarget joint error {clips.joint_err_cm.mean():.2f} cm; "
            f"foot sliding {clips.slide_source_cm_s.mean():.1f} (source) vs {clips.slide_anny_cm_s.mean():.1f} "
            f"(anny) cm/s; {ds.meta.get('build_seconds', 0)} s build ({ds.meta.get('hash', '')})")


try:  # register `python -m data_prep build body4d` when the build registry exists
    from data_prep.build import register_build

    @register_build("body4d", default=False,
                    help="4D body-motion cycles on anny: shape fits, retargeting, DTW cycles, chi (cache/body4d/)")
    def build_body4d_target(data_dir=None, quick=False) -> str:
        ds = build_dataset(Body4DConfig.quick() if quick else Body4DConfig(), data_dir)
        return summary(ds)
except ImportError:
    pass


def main(argv=None) -> int:
    import argparse

    p = argparse.ArgumentParser(prog="python -m data_prep.body4d_dataset", description=__doc__.split("\n")[0])
    p.add_argument("--data-dir")
    p.add_argument("--quick", action="store_true", help=f"subjects {', '.join(QUICK_SUBJECTS)}, 2 clips per type")
    p.add_argument("--mirror", action="store_true", help="add mirrored cycles (augmentation)")
    p.add_argument("--no-cache", action="store_true")
    a = p.parse_args(argv)
    config = Body4DConfig.quick() if a.quick else Body4DConfig()
    if a.mirror:
        config = dataclasses.replace(config, mirror=True)
    ds = build_dataset(config, a.data_dir, cache=not a.no_cache)
    with pd.option_context("display.width", 200, "display.max_columns", 40):
        print("shape fit per subject (segment-length error, cm; fitted beta):")
        print(ds.subjects.round(3).to_string(index=False))
        print("\nretargeting per source and type (joint error cm over every frame; foot sliding cm/s):")
        cols = ["joint_err_cm", "joint_err_max_cm", "slide_source_cm_s", "slide_anny_cm_s"]
        print(ds.clips.groupby(["source", "type"])[cols].mean().round(2).to_string())
        print("\ncycles per motion type and subject (without mirrored copies):")
        print(ds.counts().to_string())
        print("\ncycles per source and type, by split:")
        print(ds.counts(["source", "type"], "split").to_string())
        print("\nrejected segments per reason and type:")
        print(ds.counts("reason", "type", table="rejected").to_string())
    print(summary(ds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
