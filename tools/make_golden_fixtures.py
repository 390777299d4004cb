"""Regenerate the golden regression fixtures in ``tests/fixtures/golden/`` (after naver/anny's
``scripts/generate_regression_fixtures.py``); ``tests/test_golden.py`` recomputes each one from
its stored inputs and compares.

Run after an *intentional* change to the code a fixture pins, and commit the new ``.npz`` with
that change (say why in the message):

    python tools/make_golden_fixtures.py                 # all fixtures
    python tools/make_golden_fixtures.py chi_07_01       # one

Each ``.npz`` holds its inputs (``in_*``: clip, frames, beta, ...) and its outputs. Only derived
numbers are committed (features, chi, beta), never raw mocap; the clips come from the real data
folder (``../shared/data`` or ``$MOCAPVIZ_DATA_DIR``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

OUT_DIR = Path(__file__).resolve().parent.parent / "tests" / "fixtures" / "golden"


def _motion(clip: str, data_dir):
    from data_prep.catalog import build_catalog, load_motion
    cat = build_catalog(data_dir)
    return load_motion(cat[cat["clip"] == clip].iloc[0])


def ccnet_features(inputs: dict, data_dir) -> dict:
    """CCNet frame vectors x, trajectory control c^d and skeleton control c^s (float32) of the
    first ``in_frames`` frames of a clip at 60 fps with the 25 CCNet joints."""
    from mocapviz.features.ccnet import motion_features, prepare_motion
    m = prepare_motion(_motion(str(inputs["in_clip"]), data_dir))
    f = motion_features(m[:int(inputs["in_frames"])])
    return {"x": f.x, "traj": f.traj, "skel": f.skel}


def fitted_betas(inputs: dict, data_dir) -> dict:
    """anny shape beta (S, 6) fitted to the skeleton of each subject's clip, and the segment
    errors (S, 13) in metres after fitting."""
    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.shape_fit import fit_shapes
    skeletons = {str(s): _motion(str(c), data_dir).skeleton for s, c in zip(inputs["in_subjects"], inputs["in_clips"])}
    fit = fit_shapes(body_model(), skeletons, steps=int(inputs["in_steps"]))
    return {"beta": fit.beta, "segment_error": fit.after}


def chi_cycle(inputs: dict, data_dir) -> dict:
    """chi (100, 6K + 4) of frames [start, end] of a clip retargeted onto anny with shape
    ``in_beta``, Gamma divided by ``in_gamma_scale``."""
    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.representation import N_FRAMES, chi_joint_indices, encode
    from mocapviz.bodies.retarget import retarget
    from mocapviz.features.cycles import resample_uniform
    body = body_model()
    start, end = (int(v) for v in inputs["in_frames"])
    m = retarget(_motion(str(inputs["in_clip"]), data_dir), body.rest_skeleton(inputs["in_beta"]))
    rot, root, times = resample_uniform(m, start, end, N_FRAMES)
    return {"chi": encode(rot, root, times, chi_joint_indices(body.joint_names), inputs["in_gamma_scale"])}


# name -> (recipe, how to make its inputs from the data folder)
FIXTURES = {
    # 120 frames (2 s at 60 fps) of a CMU walk: 120 x 306 float32 features
    "ccnet_features_35_01": (ccnet_features, lambda data_dir: {"in_clip": "35_01", "in_frames": 120}),
    # one CMU and one HDM05 subject, the dataset's 100 Adam steps
    "beta_07_bd": (fitted_betas, lambda data_dir: {"in_subjects": np.array(["07", "bd"]),
                                                   "in_clips": np.array(["07_01", "HDM_bd_sneak2StepsLStart_001_120"]),
                                                   "in_steps": 100}),
    # the reference left-start walk cycle of notebook 10 on subject 07's fitted body; a fixed
    # Gamma scale (the dataset's is a statistic over its training cycles)
    "chi_07_01": (chi_cycle, lambda data_dir: {
        "in_clip": "07_01", "in_frames": np.array([134, 261]), "in_gamma_scale": np.array([0.5, 0.2, 2.0]),
        "in_beta": fitted_betas(FIXTURES["beta_07_bd"][1](data_dir), data_dir)["beta"][0]}),
}


def compute(name: str, inputs: dict, data_dir) -> dict:
    """The outputs of fixture ``name`` recomputed from its inputs by the current code."""
    return FIXTURES[name][0](inputs, data_dir)


def make(name: str, data_dir) -> Path:
    inputs = FIXTURES[name][1](data_dir)
    path = OUT_DIR / f"{name}.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **inputs, **compute(name, inputs, data_dir))
    return path


def main(argv=None) -> None:
    import torch

    from data_prep.sources import find_data_dir
    torch.set_num_threads(1)  # anny's float32 sums depend on the thread count (~1e-6 in chi)
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help=f"fixtures to write (default: all of {', '.join(FIXTURES)})")
    args = parser.parse_args(argv)
    unknown = set(args.names) - set(FIXTURES)
    if unknown:
        parser.error(f"unknown fixtures {sorted(unknown)}; known: {list(FIXTURES)}")
    data_dir = find_data_dir()
    for name in args.names or FIXTURES:
        path = make(name, data_dir)
        print(f"{path.relative_to(OUT_DIR.parent.parent.parent)}: {path.stat().st_size / 1024:.1f} kB")


if __name__ == "__main__":
    main()
