"""DTW gait-cycle segmentation on real clips against hand-marked boundaries."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocapviz.features.cycles import (EDGE_S, MAX_CYCLE_S, MIN_CYCLE_S, curve_correlation, find_cycles,
                                      half_cycles, hip_angles, hip_flexion, make_references, mirror_curves,
                                      resample_uniform, segment_cycles)

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
    np.testing.assert_allclose(hip_angles(m.mirrored()), mirror_curves(hip_angles(m)), atol=1e-9)


def test_reference_starts_at_left_hip_extension(refs):
    left = refs.left[:, 0]
    assert left[0] < left.min() + 1.0 and left[-1] < left.min() + 1.0  # starts and ends at the minimum
    assert left.max() - left.min() > 50  # a full swing of the thigh (degrees)
    np.testing.assert_array_equal(refs.right[:, :2], refs.left[:, 1::-1])  # flexion: legs swapped
    np.testing.assert_array_equal(refs.right, mirror_curves(refs.left))  # abduction too


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


def _stretched(m, factor):
    """The clip played ``factor`` times slower (same fps, more frames)."""
    return m.sample(np.arange(int((m.n_frames - 1) * factor) + 1) / factor)


def test_search_window_covers_0_3_to_3_s(catalog, refs):
    """The reference cycle (1.06 s) played 2.3x slower lasts 2.43 s, beyond the old 0.5-2x window
    (2.1 s): it is still found; played 3.2x slower (3.39 s) it is longer than 3 s: not a cycle."""
    m = _clip(catalog, "07_01")
    slow = segment_cycles(_stretched(m, 2.3), refs)
    assert any(abs(c.start - 134 * 2.3) <= 8 and abs(c.end - 261 * 2.3) <= 8 for c in slow), slow
    assert all(MIN_CYCLE_S <= c.duration(m.fps) <= MAX_CYCLE_S for c in slow)
    assert all(c.duration(m.fps) < 2.5 for c in segment_cycles(_stretched(m, 3.2), refs))


def test_a_cycle_cut_by_the_clip_edge_is_never_kept(catalog, refs):
    """07_01's reference cycle (frames 134-261) in clips cut around it: starting 0-3 frames
    before it (within EDGE_S) it is rejected as 'edge'; cut inside it (from frame 150), only
    later cycles are found; with 34 frames before it, it is found."""
    m = _clip(catalog, "07_01")
    for k in (0, 1, 2, 3):
        kept, rejected = find_cycles(m[134 - k:300], refs)
        assert all(c.start > 100 for c in kept), (k, kept)
        assert (k, 127 + k, "edge") in [(c.start, c.end, why) for c, why in rejected], (k, rejected)
    assert k < EDGE_S * m.fps
    assert all(c.start + 150 > 261 - 8 for c in segment_cycles(m[150:], refs))
    kept, _ = find_cycles(m[100:300], refs)
    assert [(c.start + 100, c.end + 100) for c in kept] == [(134, 261)]


def test_curve_correlation_is_one_for_the_same_curves_and_low_for_others(refs):
    ref = refs.left
    assert curve_correlation(ref, ref) == pytest.approx(1.0)
    assert curve_correlation(ref[::-1], ref) < 0.6  # the cycle played backwards
    assert curve_correlation(np.zeros_like(ref) + np.random.default_rng(0).normal(0, 1, ref.shape), ref) < 0.3


def test_half_cycles_by_group_median_travel():
    travel = [1.4, 1.5, 0.6, 1.3, 0.3, 0.32]
    groups = ["a", "a", "a", "a", "b", "b"]
    # group a: median 1.35, half 0.675: 0.6 is half a cycle; group b: median 0.31, none
    np.testing.assert_array_equal(half_cycles(travel, groups), [False, False, True, False, False, False])
