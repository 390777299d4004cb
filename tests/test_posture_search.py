"""The search for a z that keeps the seed's posture (mocapviz.tasks.posture_search): the measures
on hand-made motions, the cost on hand-computed cases, the candidates' spread, and the
Generator's ``z_shift`` (what the search hands on)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from data_prep import zoo as repo_zoo
from mocapviz.motion import Motion
from mocapviz.tasks.generate import Generator
from mocapviz.tasks.generation_defaults import GENERATION_MODEL
from mocapviz.tasks.posture_search import (LEAN_TOLERANCE, Posture, ZSearch, candidate_shifts, posture_cost,
                                           posture_of, search_seed_z)
from mocapviz.tasks.rig import known_body
from mocapviz.training.checkpoint import load_checkpoint

FPS = 60.0


@pytest.fixture(scope="module")
def checkpoint():
    return load_checkpoint(repo_zoo.committed_path(GENERATION_MODEL))


@pytest.fixture(scope="module")
def body(checkpoint):
    ds = checkpoint[2]["dataset"]
    return known_body(ds["joint_names"], ds["parents"])


def _still(body, frames: int = 120, root_rotation=np.eye(3), velocity=(0.0, 0.0, 0.0)) -> Motion:
    """The rest pose held, its root turned by ``root_rotation`` and gliding at ``velocity`` (m/s)."""
    rot = np.tile(np.eye(3), (frames, body.n_joints, 1, 1))
    rot[:, 0] = root_rotation
    root = np.asarray(body.offsets[0], float) + np.arange(frames)[:, None] * np.asarray(velocity) / FPS
    return Motion(body, rot, root, FPS)


def test_posture_of_a_gliding_rest_pose(body):
    """A frozen pose gliding at 1.5 m/s: pace 1.5, no activity, no lean, the root at its rest
    height above the lowest joint."""
    m = _still(body, velocity=(0.0, 0.0, 1.5))
    p = posture_of(m)
    rest = body.rest_positions()
    assert p.speed == pytest.approx(1.5, rel=1e-9)
    assert p.activity == pytest.approx(0.0, abs=1e-9)
    assert p.lean == pytest.approx(0.0, abs=1e-6)
    assert p.height == pytest.approx(rest[0, 1] - rest[:, 1].min(), rel=1e-9)


def test_posture_of_a_body_tipped_forward(body):
    """The whole body turned 20 degrees about its left-right axis towards where it faces: the
    hips -> neck vector leans 20 degrees forward from the rest's."""
    rest = body.rest_positions()
    left, right = rest[body.index("LeftUpLeg")], rest[body.index("RightUpLeg")]
    across = (left - right) / np.linalg.norm(left - right)  # the body's left, in the ground plane at rest
    forward = np.cross(across, [0.0, 1.0, 0.0])
    tip = Rotation.from_rotvec(np.radians(20.0) * np.cross([0.0, 1.0, 0.0], forward)).as_matrix()
    lean = posture_of(_still(body, root_rotation=tip)).lean
    assert abs(lean) == pytest.approx(20.0, abs=0.05)
    assert lean > 0, "tipped towards its facing direction: a forward lean"


def test_cost_on_hand_computed_cases():
    target = Posture(height=0.9, lean=10.0, speed=1.0, activity=0.5)
    assert posture_cost(target, target) == 0.0
    assert posture_cost(Posture(0.9 * 1.05, 10.0, 1.0, 0.5), target) == pytest.approx(1.0)
    assert posture_cost(Posture(0.9, 10.0 - LEAN_TOLERANCE, 1.0, 0.5), target) == pytest.approx(1.0)
    # pace counts from 0.1 m/s: (2.1 + 0.1) / (1.0 + 0.1) = 2
    assert posture_cost(Posture(0.9, 10.0, 2.1, 0.5), target) == pytest.approx(1.0)
    # a standing seed (pace 0) keeps a defined cost: 0.1 -> 0.3 m/s is a factor 2 from 0.1
    standing = Posture(0.9, 10.0, 0.0, 0.5)
    assert posture_cost(Posture(0.9, 10.0, 0.1, 0.5), standing) == pytest.approx(1.0)
    # the four add: 5 % too tall and one tolerance too upright
    assert posture_cost(Posture(0.9 * 1.05, 10.0 - LEAN_TOLERANCE, 1.0, 0.5), target) == pytest.approx(2.0)
    assert posture_cost(Posture(0.9, 10.0 - 2 * LEAN_TOLERANCE, 1.0, 0.5), target) == pytest.approx(4.0)


def test_candidates_are_the_seed_z_then_the_type_spread(checkpoint):
    prior = checkpoint[0].type_prior
    shifts = candidate_shifts(prior, 3, 20000, 2.0, rng_seed=0)
    assert np.all(shifts[0] == 0.0)
    cov = np.cov(shifts[1:].T)
    want = 4.0 * prior.chol[3] @ prior.chol[3].T
    assert np.abs(cov - want).max() < 0.05 * np.abs(want).max()
    assert np.array_equal(shifts, candidate_shifts(prior, 3, 20000, 2.0, rng_seed=0))


def _run(checkpoint, seed_x, skel, types, z_shift=None, batch=1):
    model, norm, _ = checkpoint
    g = Generator(model, norm, batch=batch, z_source="seed", z_shift=z_shift)
    rep = lambda a: np.repeat(a[None], batch, axis=0)  # noqa: E731
    out = g.run(rep(seed_x), rep(skel), rep(types), 30)
    return out, g


@pytest.fixture(scope="module")
def seed_frames(checkpoint):
    """A real walk's frame vectors (the dataset's test split, first 2 s) and its c^s, walk type."""
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    ds = build_dataset(DatasetConfig(), progress=False)
    row = int(np.flatnonzero((ds.clips.split == "test").values & (ds.clips.type == "walk").values)[0])
    start = int(ds.clips.start.values[row])
    types = np.zeros(len(checkpoint[2]["dataset"]["motion_types"]), np.float32)
    types[list(checkpoint[2]["dataset"]["motion_types"]).index("walk")] = 1.0
    return ds.x[start:start + 120].astype(np.float32), ds.skel[row].astype(np.float32), types


def test_z_shift_adds_to_the_seed_z(checkpoint, seed_frames):
    """A zero shift changes nothing; a shift lands exactly on the z read from the seed, and
    moves the generated frames."""
    seed_x, skel, types = seed_frames
    plain, g0 = _run(checkpoint, seed_x, skel, types)
    zero, _ = _run(checkpoint, seed_x, skel, types, z_shift=np.zeros((1, checkpoint[0].cfg.latent)))
    np.testing.assert_array_equal(plain.x, zero.x)
    shift = np.full((1, checkpoint[0].cfg.latent), 0.5, np.float32)
    moved, g1 = _run(checkpoint, seed_x, skel, types, z_shift=shift)
    np.testing.assert_allclose(g1._z_seed, g0._z_seed + shift, atol=1e-6)
    assert np.abs(moved.x[0, 120:] - plain.x[0, 120:]).max() > 1e-3


def test_search_picks_the_cheapest_candidate(checkpoint, seed_frames, body):
    """The chosen candidate is the cheapest of both rounds, its cost that of its own rollout
    (rerun on its own with the chosen shift: the batch does not change a character's frames);
    round 2 starts from round 1's best, so its best is no worse."""
    model, norm, _ = checkpoint
    seed_x, skel, types = seed_frames
    target = Posture(height=0.85, lean=15.0, speed=1.2, activity=0.6)
    found = search_seed_z(model, norm, seed_x, skel, types, np.full((len(seed_x), 12), np.nan, np.float32), body,
                          target, candidates=6, seconds=1.0, spreads=(2.0, 0.5), pace="seed")
    assert found.chosen == int(np.argmin(found.costs)) and len(found.postures) == 12
    assert found.costs[6:].min() <= found.costs[:6].min()
    assert found.costs[6] == pytest.approx(found.costs[:6].min(), rel=1e-6)  # round 1's best, rerun
    alone = Generator(model, norm, batch=1, pace="seed", z_source="seed", z_shift=found.shift[None]).run(
        seed_x[None], skel[None], types[None], 60, seed_traj=np.full((1, len(seed_x), 12), np.nan, np.float32))
    m = alone.motion(0, body, include_seed=False, ik=True)
    p = posture_of(m[m.n_frames // 2:])
    assert posture_cost(p, target) == pytest.approx(found.costs[found.chosen], rel=1e-3, abs=1e-4)
    assert search_seed_z(model, norm, seed_x, skel, types, seed_x[:, :12] * np.nan, body, target, candidates=1,
                         seconds=1.0, spreads=(2.0,), pace="seed") is None


def test_summary_says_what_was_kept():
    target = Posture(height=0.9, lean=10.0, speed=1.0, activity=0.5)
    found = ZSearch(np.zeros(2), 1, np.array([4.0, 0.25]), [Posture(1.0, 0.0, 1.0, 0.5), Posture(0.927, 12.5, 1.1, 0.5)],
                    target)
    assert found.summary() == ("z searched over 2 codes: kept code 1 (cost 4.00 with the seed's z, 0.25 kept); in its "
                               "trial run, root height 1.030x the seed's, lean +12.5 degrees (seed +10.0), pace 1.10 m/s "
                               "(seed 1.00)")
    assert "kept the seed's own z" in ZSearch(np.zeros(2), 0, np.array([0.1]), [target], target).summary()
