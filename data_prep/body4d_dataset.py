"""Build and cache the 4D body-motion dataset (multi-frame 4D motion paper, §3.1, §4.1-4.2).

Real mocap (CMU walk/run BVH, HDM05 jog/sneak/hop ASF/AMC) -> per subject, anny's body shape
fitted to the subject's bone lengths -> every clip retargeted onto that body -> single gait
cycles found by DTW on hip rotation curves -> each cycle as chi = [Theta, Gamma, Phi]
(100 time-stamped frames) with the subject's beta. Meshes are not stored: mesh a cycle on
demand with :meth:`mocapviz.datasets.body4d.Body4DDataset.mesh`.

Train/test split by subject (whole people held out, so that the test bodies are unseen by a
shape-conditioned decoder): HDM05 actors mm and tr (the hold-out the catalog and CCNet use)
plus CMU subject 35 (walk) and 09 (run), so that every motion type with cycles has test
cycles. The reference cycle's subject (CMU 07) stays in training.

``python -m data_prep build body4d [--quick]`` or ``python -m data_prep.body4d_dataset``.
Cached under ``cache/body4d/`` keyed by the config, the data files, the code and anny's version.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

import mocapviz.datasets.body4d as container
from data_prep.cached import load_or_build
from data_prep.catalog import CACHE_DIR, build_catalog, cache_key, load_motion
from data_prep.sources import find_data_dir
from mocapviz.datasets.body4d import Body4DDataset

DATASET_VERSION = 1
# The cyclic locomotion clips and the short type names used in the dataset.
MOTION_TYPES = {"walk": "walk", "run": "run", "jogLeftCircle4StepsRstart": "jog",
                "sneak2StepsLStart": "sneak", "hopBothLegs1hops": "hop"}
# Left-start reference cycle: CMU 07_01 (subject 07, straight walk), from the left hip's
# maximal extension (left toe-off) at frame 134 to the next at frame 261 (1.06 s), chosen by
# hand on the plot of the hip flexion curves; its mirror image is the right-start reference.
REFERENCE_CLIP = "07_01"
REFERENCE_FRAMES = (134, 261)
TEST_SUBJECTS = ("mm", "tr", "cmu35", "cmu09")
QUICK_SUBJECTS = ("cmu07", "cmu09", "bd")


@dataclass(frozen=True)
class Body4DConfig:
    subjects: tuple = ()  # empty: every subject with cyclic clips
    clips_per_type: int = 0  # per subject and type; 0 = all
    threshold: float = 10.0  # DTW distance threshold (degrees, see features.cycles)
    n_frames: int = 100
    mirror: bool = False  # add left/right mirrored cycles (flagged) as augmentation
    fit_steps: int = 100
    test_subjects: tuple = TEST_SUBJECTS

    def key(self) -> str:
        return json.dumps(dataclasses.asdict(self), sort_keys=True)

    @classmethod
    def quick(cls) -> "Body4DConfig":
        return cls(subjects=QUICK_SUBJECTS, clips_per_type=2)


# ---------------------------------------------------------------------------------- build
def _catalog_rows(config: Body4DConfig, root: Path) -> pd.DataFrame:
    cat = build_catalog(root)
    cat = cat[cat["motion_type"].isin(list(MOTION_TYPES))].copy()
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

    h = hashlib.sha256(f"v{DATASET_VERSION}\n{config.key()}\n{cache_key(root)}\nanny={anny.__version__}\n".encode())
    for p in sorted(Path(bodies.__file__).parent.glob("*.py")) + [Path(cycles_mod.__file__), Path(container.__file__),
                                                                  Path(__file__)]:
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def reference_cycles(root: Path | None = None):
    """The left-start reference (REFERENCE_CLIP, REFERENCE_FRAMES) and its mirror."""
    from mocapviz.features.cycles import make_references

    cat = build_catalog(root)
    row = cat[cat["clip"] == REFERENCE_CLIP]
    if row.empty:
        raise ValueError(f"reference clip {REFERENCE_CLIP} is not in the catalog of {root}")
    return make_references(load_motion(row.iloc[0]), *REFERENCE_FRAMES)


def fit_subject_shapes(cat: pd.DataFrame, body, steps: int = 100):
    """Shape fit of every subject in ``cat`` (skeleton of its first clip)."""
    from mocapviz.bodies.shape_fit import fit_shapes

    skeletons = {s: load_motion(g.iloc[0]).skeleton for s, g in cat.groupby("subject", sort=True)}
    return fit_shapes(body, skeletons, steps=steps), skeletons


def _split_of(subject: str, config: Body4DConfig) -> str:
    return "test" if subject in config.test_subjects else "train"


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


def _build(config: Body4DConfig, root: Path, progress: bool) -> Body4DDataset:
    from mocapviz.bodies.anny_model import BETA_LABELS, body_model
    from mocapviz.bodies.representation import (DROPPED_JOINTS, PHI_SCALE, canonicalise, chi_joint_indices,
                                                encode)
    from mocapviz.bodies.retarget import rest_alignment, retarget, retarget_report
    from mocapviz.features.cycles import resample_uniform, segment_cycles

    t0 = time.perf_counter()
    body = body_model()
    cat = _catalog_rows(config, root)
    refs = reference_cycles(root)
    fit, skeletons = fit_subject_shapes(cat, body, config.fit_steps)
    betas = dict(zip(fit.subjects, fit.beta))
    subjects = fit.report()
    subjects["height_m"] = body.measurements(fit.beta)["height"]
    subjects["source"] = ["hdm05" if not s.startswith("cmu") else "cmu" for s in subjects["subject"]]
    subjects["split"] = [_split_of(s, config) for s in subjects["subject"]]
    kept = chi_joint_indices(body.joint_names)

    targets = {s: body.rest_skeleton(betas[s]) for s in betas}
    chis, rows, clip_rows = [], [], []
    for r in tqdm(list(cat.itertuples(index=False)), desc="body4d clips", disable=not progress):
        src = load_motion(r._asdict())
        tgt = targets[r.subject]
        variants = [(src, False)] + ([(src.mirrored(), True)] if config.mirror else [])
        for motion, mirrored in variants:
            anny_motion = retarget(motion, tgt, rest_alignment(motion.skeleton, tgt))
            if not mirrored:
                clip_rows.append(dict(retarget_report(motion, anny_motion), subject=r.subject,
                                      type=MOTION_TYPES[r.motion_type], source=r.source))
            for cyc in segment_cycles(motion, refs, threshold=config.threshold):
                rot, rootp, times = resample_uniform(anny_motion, cyc.start, cyc.end, config.n_frames)
                chis.append(encode(rot, rootp, times, kept, np.ones(3)))
                _, _, yaw, root0 = canonicalise(rot, rootp)
                rows.append(dict(subject=r.subject, source=r.source, clip=r.clip, motion_type=r.motion_type,
                                 type=MOTION_TYPES[r.motion_type], start=cyc.start, end=cyc.end, side=cyc.side,
                                 dtw_distance=cyc.distance, duration_s=cyc.duration(motion.fps),
                                 mirrored=mirrored, split=_split_of(r.subject, config), yaw=yaw,
                                 root0_y=float(root0[1])))
    chi = np.stack(chis).astype(np.float32) if chis else np.zeros((0, config.n_frames, 6 * len(kept) + 4), np.float32)
    n_theta = 6 * len(kept)
    gamma_scale = np.maximum(np.abs(chi[..., n_theta:n_theta + 3]).max(axis=(0, 1)), 1e-6) if len(chi) else np.ones(3)
    chi[..., n_theta:n_theta + 3] /= gamma_scale
    cycles = pd.DataFrame(rows)
    beta = np.stack([betas[s] for s in cycles["subject"]]).astype(np.float32) if rows else np.zeros((0, 6), np.float32)
    meta = dict(version=DATASET_VERSION, config=json.loads(config.key()), data_dir=str(root),
                joint_names=list(body.joint_names), chi_joints=[body.joint_names[k] for k in kept],
                dropped_joints=list(DROPPED_JOINTS), beta_labels=list(BETA_LABELS),
                gamma_scale=gamma_scale.tolist(), phi_scale=PHI_SCALE, n_frames=config.n_frames,
                chi_layout=f"[Theta {n_theta} = {len(kept)} joints x 6D minus identity, Gamma 3, Phi 1]",
                reference=dict(clip=REFERENCE_CLIP, frames=list(REFERENCE_FRAMES)),
                test_subjects=list(config.test_subjects),
                build_seconds=round(time.perf_counter() - t0, 1))
    return Body4DDataset(chi, beta, cycles, subjects, pd.DataFrame(clip_rows), meta)


def summary(ds: Body4DDataset) -> str:
    clips = ds.clips
    return (f"{len(ds)} cycles ({(ds.cycles['split'] == 'test').sum()} test) from {len(clips)} clips of "
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
    print(summary(ds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
