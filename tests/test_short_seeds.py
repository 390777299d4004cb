"""Seeds shorter than CCNet's receptive field (paper Table 7): the generate command takes
any seed of one frame or more, as the paper's causal network does (zero padding before the
first frame), and warns below the receptive field + 1 frames (42 at 60 fps for the command's
model: a frame vector needs the frame before it).

The seeds are the first frames of a real CMU walk (35_01, after its T-pose frame); the model is
the generate command's default. Measured when written (3 s generated, mean output): ground speed
over the last second 1.37 m/s (1 frame), 1.17 (5), 1.37 (41), 1.29 (42), 1.11 (120); mean joint
speed 0.40-0.43 m/s for all of them. The take walks at 1.29 m/s, mean joint speed 0.37.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from data_prep import zoo as repo_zoo
from mocapviz import metrics
from mocapviz.cli import main
from mocapviz.features.ccnet import FeatureLayout, motion_features
from mocapviz.features.phase import seed_phase
from mocapviz.io.bvh import read_bvh, write_bvh
from mocapviz.skeleton_map import map_skeleton
from mocapviz.tasks.generate_bvh import ShortSeedWarning, generate_from_seed, load_seed, seed_features, seed_rig
from mocapviz.tasks.generation_defaults import GENERATION_MODEL
from mocapviz.training.checkpoint import load_checkpoint

CMU_WALK = "cmu/35/35_01.bvh"
FPS = 60
SECONDS = 3.0
# a real walk's slowest 1 s window of mean joint speed is 0.15 m/s (mocapviz.metrics.FROZEN_SPEED's note)
WALKING_ACTIVITY = 0.15
WALKING_SPEED = 0.1  # m/s over the last generated second: the body goes somewhere


@pytest.fixture(scope="module")
def checkpoint():
    return load_checkpoint(repo_zoo.committed_path(GENERATION_MODEL))


@pytest.fixture(scope="module")
def seed(data_dir):
    return load_seed(data_dir / CMU_WALK)


def last_second(motion):
    tail = motion[-FPS:]
    local = metrics.local_positions(tail.positions(), tail.skeleton)
    return metrics.root_speed(tail.root_positions, FPS), metrics.activity(local, FPS)


def test_the_receptive_field_is_what_the_warning_counts_from(checkpoint):
    assert checkpoint[0].cfg.receptive_field == 41


@pytest.mark.parametrize("n_seed", [1, 5, 41])
def test_a_short_seed_generates_walks_and_warns(checkpoint, seed, tmp_path, n_seed):
    with pytest.warns(ShortSeedWarning, match=rf"{n_seed} frames? at 60 fps.*less context"):
        result = generate_from_seed(seed, *checkpoint, types=["walk"], seconds=SECONDS, seed_seconds=n_seed / FPS)
    n_gen = int(SECONDS * FPS)
    assert result.n_seed == n_seed and result.model_motion.n_frames == n_gen
    out = tmp_path / f"seed{n_seed}.bvh"
    write_bvh(result.motion, out)
    back = read_bvh(out)
    assert back.n_frames == n_seed + n_gen and back.fps == FPS
    assert np.isfinite(back.positions()).all()
    speed, activity = last_second(result.model_motion)
    assert speed > WALKING_SPEED, f"{n_seed}-frame seed: the last second moves at {speed:.3f} m/s"
    assert activity > WALKING_ACTIVITY, f"{n_seed}-frame seed: the pose changes at {activity:.3f} m/s"


@pytest.mark.parametrize("n_seed", [42, 120])
def test_a_seed_covering_the_receptive_field_does_not_warn(checkpoint, seed, n_seed):
    with warnings.catch_warnings():
        warnings.simplefilter("error", ShortSeedWarning)
        result = generate_from_seed(seed, *checkpoint, types=["walk"], seconds=1.0, seed_seconds=n_seed / FPS)
    assert result.n_seed == n_seed


def test_a_one_frame_seed_follows_a_path(checkpoint, seed):
    with pytest.warns(ShortSeedWarning):
        result = generate_from_seed(seed, *checkpoint, types=["walk"], seconds=4.0, seed_seconds=1 / FPS,
                                    path_xz=[[0.0, 0.0], [0.0, 4.0]])
    assert result.motion.n_frames == 1 + 240
    assert np.isfinite(result.model_motion.root_positions).all()


def model_seed(seed, checkpoint, n):
    model, norm, meta = checkpoint
    seed60 = seed.resample(FPS)[:n]
    names = map_skeleton(seed60.skeleton).mapping
    return seed_rig(seed60, names, meta["dataset"], norm).to_model(seed60)


def test_seed_features_of_one_and_two_frames(checkpoint, seed):
    """One frame: one frame vector, its pose at rest (no velocity). Two frames: the second
    frame's vector, as the longer seed has it (but the contacts: their floor is per seed)."""
    m3 = model_seed(seed, checkpoint, 3)
    layout = FeatureLayout(m3.skeleton.n_joints)
    b = layout.x_blocks
    one, root1 = seed_features(m3[:1], FPS)
    assert one.x.shape == (1, layout.n_x) and root1.shape == (1, 3) and one.traj.shape == (1, 12)
    for block in ("angvel", "vel", "root"):
        moving = one.x[0, b[block]] if block != "root" else one.x[0, b["root"]][:3]
        np.testing.assert_allclose(moving, 0.0, atol=1e-5)
    np.testing.assert_allclose(one.start_root, m3.root_positions[0])
    two, root2 = seed_features(m3[:2], FPS)
    full = motion_features(m3, FPS)
    assert two.x.shape == (1, layout.n_x)
    keep = np.ones(layout.n_x, bool)
    keep[b["contact"]] = False
    np.testing.assert_allclose(two.x[0, keep], full.x[0, keep], atol=1e-5)
    np.testing.assert_allclose(two.start_root, full.start_root)
    assert two.start_heading == pytest.approx(full.start_heading)
    np.testing.assert_allclose(root2, m3.root_positions[1:2])


@pytest.mark.parametrize("n_seed", [2, 5, 10, 20, 41])
def test_a_seed_shorter_than_a_cycle_turns_at_its_types_usual_pace(checkpoint, seed, n_seed):
    """A pace fitted to part of a stride is a guess (0.4-4 Hz on this 0.88 Hz walk); such a
    seed's phase turns at the type prior's usual pace for walks instead."""
    walk_hz = float(checkpoint[0].type_prior.phase_hz[0])
    feats, _ = seed_features(model_seed(seed, checkpoint, n_seed), FPS)
    layout = FeatureLayout.of_model(checkpoint[0].cfg)
    _, pace = seed_phase(feats.x, layout, FPS, fallback_hz=walk_hz)
    assert pace * FPS / (2 * np.pi) == pytest.approx(walk_hz)


def test_the_command_takes_a_one_frame_file_and_says_so_in_one_line(data_dir, tmp_path, capsys):
    full = read_bvh(data_dir / CMU_WALK)
    one = tmp_path / "one_frame.bvh"
    write_bvh(full[30:31], one)
    out = tmp_path / "from_one.bvh"
    code = main(["generate", "--seed", str(one), "--seconds", "1", "--type", "walk", "--out", str(out),
                 "--model", str(repo_zoo.committed_path(GENERATION_MODEL))])
    err = capsys.readouterr().err
    assert code == 0, err
    warned = [line for line in err.splitlines() if "warning:" in line]
    assert len(warned) == 1 and "1 frame at 60 fps" in warned[0] and "less context" in warned[0]
    assert read_bvh(out).n_frames == 1 + 60
    code = main(["generate", "--seed", str(data_dir / CMU_WALK), "--seed-seconds", "0.7", "--seconds", "1",
                 "--out", str(tmp_path / "from_42.bvh"), "--model", str(repo_zoo.committed_path(GENERATION_MODEL))])
    err = capsys.readouterr().err
    assert code == 0 and "warning" not in err, err
    assert read_bvh(tmp_path / "from_42.bvh").n_frames == 42 + 60
