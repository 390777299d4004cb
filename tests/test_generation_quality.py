"""The seeds of the generation-quality benchmark (issue 9's "Done when"): locomotion and
repeatable motion from the test split, one per entry of LOCOMOTION_SEEDS."""

import pytest

from mocapviz.tasks.generation_quality import LOCOMOTION_SEEDS, SEED_FRAMES, locomotion_seeds, moves_like_real


@pytest.fixture(scope="module")
def ds(data_dir):
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    return build_dataset(DatasetConfig.quick(), data_dir, progress=False)


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
