"""The seeds of the generation-quality benchmark (the moving bar): locomotion and
repeatable motion from the test split, one per entry of LOCOMOTION_SEEDS; the bar a seed must
clear; the pose distance, which must see a pose of the wrong motion type."""

import numpy as np
import pytest

from mocapviz.tasks.generation_quality import (LOCOMOTION_SEEDS, SEED_FRAMES, TypeBanks, locomotion_seeds,
                                               moves_like_real, pose_bank, pose_distance, real_pose_distance,
                                               within_issue_bar)


def test_locomotion_seeds_are_distinct_test_clips_of_the_named_kinds(ds):
    rows = locomotion_seeds(ds)
    clips = ds.clips.iloc[rows]
    assert len(set(rows)) == len(rows) == len(LOCOMOTION_SEEDS)  # the quick dataset holds every kind
    assert (clips.split == "test").all()
    assert ((clips.stop - clips.start) >= SEED_FRAMES).all()
    # in the order of LOCOMOTION_SEEDS: plain walk is not a turning walk, Bandai's run is labelled jog
    assert list(clips.type) == [t for t, _ in LOCOMOTION_SEEDS]
    assert list(clips.description[:4]) == ["walk", clips.description.iloc[1], "run", clips.description.iloc[3]]
    assert clips.description.iloc[1].startswith("walk-turn-") and clips.description.iloc[3].startswith("jog")
    # the held-out HDM05 subject supplies what only HDM05 has
    assert set(clips.subject[clips.type.isin(["sneak", "hop"])]) == {"tr"}


def test_moves_like_real_by_hand():
    walk = dict(freezing_share=0.0, activity_ratio=1.0, jitter_ratio=1.0, pose_distance_ratio=1.0,
                root_speed_ratio=1.0, root_speed_difference=0.0)
    assert moves_like_real(walk)
    for key, bad in (("freezing_share", 0.1), ("activity_ratio", 0.4), ("activity_ratio", 2.1),
                     ("jitter_ratio", 3.5), ("pose_distance_ratio", 6.0)):
        assert not moves_like_real({**walk, key: bad}), key
    # a walk (1.1 m/s) gliding at 3 m/s fails; waving in place (0.03 m/s) at 0.01 m/s passes
    assert not moves_like_real({**walk, "root_speed_ratio": 2.7, "root_speed_difference": 1.9})
    assert not moves_like_real({**walk, "root_speed_ratio": 0.3, "root_speed_difference": -0.8})
    assert moves_like_real({**walk, "root_speed_ratio": 0.33, "root_speed_difference": -0.02})


def test_issue_bar_by_hand():
    """The moving bar reads freezing, activity and jitter only: poses far from real ones or a
    gliding root pass it, and fail moves_like_real."""
    walk = dict(freezing_share=0.0, activity_ratio=1.0, jitter_ratio=1.0, pose_distance_ratio=1.0,
                root_speed_ratio=1.0, root_speed_difference=0.0)
    assert within_issue_bar(walk)
    for key, bad in (("freezing_share", 0.1), ("activity_ratio", 0.49), ("activity_ratio", 2.1), ("jitter_ratio", 3.01)):
        assert not within_issue_bar({**walk, key: bad}), key
    odd = {**walk, "pose_distance_ratio": 6.0, "root_speed_ratio": 2.7, "root_speed_difference": 1.9}
    assert within_issue_bar(odd) and not moves_like_real(odd)


def test_lying_down_is_far_from_the_walk_poses_but_near_some_training_pose(ds):
    """A held-out clip of lying down, measured as if it were a generated walk: against the walk
    poses it sits 6-8x as far as the held-out real walks (quick dataset); against every training
    pose (the measure before the phase model) it sat nearer than they do, so a walk seed that
    folded onto the floor passed."""
    banks, everything = TypeBanks(ds), pose_bank(ds)
    walk_ref = real_pose_distance(ds, banks["walk"], "walk")
    rows = np.flatnonzero(((ds.clips.type == "lie_down_floor") & (ds.clips.split == "test")).values)[:3]
    assert len(rows) == 3
    for i in rows:
        lying = ds.clip_motion(int(i))
        assert pose_distance(lying, banks["walk"]) > 4 * walk_ref
        assert pose_distance(lying, everything) < real_pose_distance(ds, everything, "walk") * 1.5
    # the held-out real walks themselves: within the spread of their own mean
    walks = np.flatnonzero(((ds.clips.type == "walk") & (ds.clips.split != "train")).values)
    ratios = [pose_distance(ds.clip_motion(int(i)), banks["walk"]) / walk_ref for i in walks]
    assert max(ratios) < 2.0
    assert set(banks) == {"walk"} and len(banks["walk"]) < len(everything)
