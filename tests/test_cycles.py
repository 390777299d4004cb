"""DTW gait-cycle segmentation on real clips against hand-marked boundaries."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocapviz.features.cycles import (MAX_CYCLE_S, MIN_CYCLE_S, hip_flexion, make_references,
                                      mirror_curves, resample_uniform, segment_cycles)

FIXTURE = json.loads((Path(__file__).parent / "fixtures" / "cycles_35_01.json").read_text())


@pytest.fixture(scope="session")
def catalog(data_dir):
    from data_prep.catalog import build_catalog
    return build_catalog(data_dir)


def _clip(catalog, name):
    from data_prep.catalog import load_motion
    return load_motion(catalog[catalog["clip"] == name].iloc[0])


@pytest.fixture(scope="session")
def refs(catalog):
    from data_prep.body4d_dataset import REFERENCE_CLIP, REFERENCE_FRAMES
    return make_references(_clip(catalog, REFERENCE_CLIP), *REFERENCE_FRAMES)


def test_mirrored_curves_are_the_curves_of_the_mirrored_motion(catalog):
    m = _clip(catalog, "07_01")
    np.testing.assert_allclose(hip_flexion(m.mirrored()), mirror_curves(hip_flexion(m)), atol=1e-9)


def test_reference_starts_at_left_hip_extension(refs):
    left = refs.left[:, 0]
    assert left[0] < left.min() + 1.0 and left[-1] < left.min() + 1.0  # starts and ends at the minimum
    assert left.max() - left.min() > 50  # a full swing of the thigh (degrees)
    np.testing.assert_array_equal(refs.right, refs.left[:, ::-1])


def test_segmentation_matches_hand_marked_boundaries(catalog, refs):
    m = _clip(catalog, FIXTURE["clip"])
    cycles = segment_cycles(m, refs)
    assert len(cycles) >= 2
    tol = 8  # frames at 120 fps: the search grid is 4 frames (30 fps)
    for c in cycles:
        marks = np.array(FIXTURE[c.side])
        assert np.abs(marks - c.start).min() <= tol, (c, marks)
        assert np.abs(marks - c.end).min() <= tol, (c, marks)
        assert MIN_CYCLE_S <= c.duration(m.fps) <= MAX_CYCLE_S
    # two consecutive hand-marked cycles of the same side are both found
    found = {(c.side, int(np.argmin(np.abs(np.array(FIXTURE[c.side]) - c.start)))) for c in cycles}
    assert len(found) >= 2


@pytest.mark.parametrize("motion_type", ["squat1Reps", "hopBothLegs1hops"])
def test_no_cycle_when_both_legs_move_together(catalog, refs, motion_type):
    """Squats and two-legged hops flex both hips in phase: no alternating gait cycle."""
    from data_prep.catalog import load_motion
    for _, row in catalog[catalog.motion_type == motion_type].iloc[:3].iterrows():
        assert segment_cycles(load_motion(row), refs) == [], row["clip"]


def test_resample_uniform_hits_the_end_frames(catalog):
    m = _clip(catalog, "07_01")
    rot, root, t = resample_uniform(m, 134, 261, 100)
    assert rot.shape == (100, m.skeleton.n_joints, 3, 3) and t.shape == (100,)
    np.testing.assert_allclose(rot[[0, -1]], m.rotations[[134, 261]], atol=1e-9)
    np.testing.assert_allclose(root[[0, -1]], m.root_positions[[134, 261]], atol=1e-12)
    assert t[0] == 0 and t[-1] == pytest.approx((261 - 134) / 120)
    np.testing.assert_allclose(np.diff(t), t[-1] / 99)
