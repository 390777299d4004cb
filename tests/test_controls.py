"""The control sources of generation (mocapviz.tasks.controls) on hand-computed cases, and the
generator fed by them: a source object gives exactly what the old keyword arguments gave."""

import numpy as np
import pytest

from mocapviz.features.ccnet import FeatureLayout, Normaliser
from mocapviz.features.motion_types import one_hot
from mocapviz.tasks.controls import ClipControls, FreeRunning, PathControls, Steered, path_speed, plan_speed

LAYOUT = FeatureLayout(1, 3)           # one joint: x is 18 wide, its root block x[12:16]
ROOT = LAYOUT.x_blocks["root"]


def normaliser(traj_mean=0.0, traj_std=1.0) -> Normaliser:
    """Identity for x (so x_t's root block is raw) and c^s; c^d (c - mean) / std."""
    n = LAYOUT.n_x - 2
    return Normaliser(np.zeros(n, np.float32), np.ones(n, np.float32), np.zeros(1, np.float32),
                      np.ones(1, np.float32), np.full(12, traj_mean, np.float32), np.full(12, traj_std, np.float32))


def straight(speed: float, batch: int = 1) -> np.ndarray:
    """A raw c^d (B, 12) straight ahead (+Z) at ``speed`` m/s: point k at (0, speed * (k+1) / 6)."""
    c = np.zeros((batch, 12), np.float32)
    c[:, 1::2] = speed * np.arange(1, 7) / 6
    return c


def test_clip_controls_repeat_the_clips_cd_cyclically_normalised():
    traj = np.arange(3, dtype=np.float32)[None, :, None] * np.ones((1, 3, 12), np.float32)   # row k: all k
    src = ClipControls(traj)
    src.start(normaliser(traj_mean=1.0, traj_std=2.0), LAYOUT, 1, 2)
    x, pred = np.zeros((1, LAYOUT.n_x), np.float32), np.zeros((1, 12), np.float32)
    got = [src.next(t, x, pred)[0, 0] for t in range(6)]        # frames 1..6: rows 1, 2, 0, 1, 2, 0
    np.testing.assert_array_equal(got, [0.0, 0.5, -0.5, 0.0, 0.5, -0.5])


def test_path_controls_are_the_path_ahead_of_the_integrated_root_in_its_heading_frame():
    # the path goes along +Z, 0.1 m a frame; the character faces +Z and moves 6 m/s (0.1 m a frame)
    path = np.stack([np.zeros(100), 0.1 * np.arange(100)], -1)[None]
    src = PathControls(path, np.zeros((1, 3)), np.zeros(1))
    src.start(normaliser(), LAYOUT, 1, 2)
    x = np.zeros((1, LAYOUT.n_x), np.float32)
    x[0, ROOT] = (0.0, 6.0, 0.0, 0.9)
    c = src.next(0, x, None)                   # root after frame 0: z = 0.1; points of frames 11..61
    np.testing.assert_allclose(c[0].reshape(6, 2), np.stack([np.zeros(6), np.arange(1, 7)], 1), atol=1e-6)
    np.testing.assert_allclose(src.root_xz, [[0.0, 0.1]])
    # past the path's end its last point is kept: frame 91 asks for point 151 -> point 99 (z 9.9),
    # from the root moved one more frame (z 0.2)
    np.testing.assert_allclose(src.next(90, x, None)[0, -2:], [0.0, 9.9 - 0.2], atol=1e-5)


def test_path_controls_turn_world_points_into_the_characters_heading_frame():
    # the character faces world +X (heading pi/2) and stands still; a point 1 m along +X is
    # straight ahead (0, 1), one 1 m along -Z is to its left (+X in the heading frame: facing +Z,
    # left is +X), one along +Z to its right
    ahead = np.tile([[1.0, 0.0]], (80, 1))[None]
    left, right = np.tile([[0.0, -1.0]], (80, 1))[None], np.tile([[0.0, 1.0]], (80, 1))[None]
    for path, want in ((ahead, (0.0, 1.0)), (left, (1.0, 0.0)), (right, (-1.0, 0.0))):
        src = PathControls(path, np.zeros((1, 3)), np.full(1, np.pi / 2))
        src.start(normaliser(), LAYOUT, 1, 2)
        c = src.next(0, np.zeros((1, LAYOUT.n_x), np.float32), None)
        np.testing.assert_allclose(c[0].reshape(6, 2), np.tile(want, (6, 1)), atol=1e-6)


def test_path_controls_integrate_the_yaw_rate():
    # turning at pi/2 rad/s for 60 frames: a quarter turn, the character then faces +X
    src = PathControls(np.tile([[1.0, 0.0]], (200, 1))[None], np.zeros((1, 3)), np.zeros(1))
    src.start(normaliser(), LAYOUT, 1, 2)
    x = np.zeros((1, LAYOUT.n_x), np.float32)
    x[0, ROOT] = (0.0, 0.0, np.pi / 2, 0.9)
    for t in range(60):
        c = src.next(t, x, None)
    np.testing.assert_allclose(src.heading, [np.pi / 2], rtol=1e-6)
    np.testing.assert_allclose(c[0].reshape(6, 2), np.tile((0.0, 1.0), (6, 1)), atol=1e-5)


def test_free_running_holds_the_seeds_plan_speed_until_the_type_changes():
    """pace "seed": from the seed's last fed c^d (2.4 m/s) on, the predicted plan (1.2 m/s) is
    stretched to 2.4 m/s, per character until its type changes; "network" leaves it alone."""
    n_seed, pred = 4, straight(1.2, 2)
    x = np.zeros((2, LAYOUT.n_x), np.float32)
    src = FreeRunning("seed")
    src.start(normaliser(), LAYOUT, 2, n_seed)
    assert src.next(0, x, pred) is pred                   # no held speed yet: the prediction
    src.fed(1, straight(9.0, 2))                          # not the seed's last c^d (frame 2 of 4)
    assert src.speed is None
    src.types_changed(np.array([True, False]))            # before the seed's end: nothing to release
    src.fed(2, straight(2.4, 2))                          # fed with frame 2 for frame 3, the seed's last
    np.testing.assert_allclose(src.speed, [2.4, 2.4], rtol=1e-6)
    held = src.next(3, x, pred)
    np.testing.assert_allclose(held, straight(2.4, 2), rtol=1e-6)
    np.testing.assert_allclose(plan_speed(held), [2.4, 2.4], rtol=1e-6)
    src.types_changed(np.array([True, False]))            # character 0 becomes, say, a jog
    mixed = src.next(4, x, pred)
    np.testing.assert_array_equal(mixed[0], pred[0])
    np.testing.assert_allclose(mixed[1], straight(2.4)[0], rtol=1e-6)
    network = FreeRunning("network")
    network.start(normaliser(), LAYOUT, 2, n_seed)
    network.fed(2, straight(2.4, 2))
    assert network.next(3, x, pred) is pred
    with pytest.raises(ValueError, match="pace"):
        FreeRunning("user")


def test_free_running_holds_the_seeds_last_known_plan_over_the_predicted_one():
    """A seed cut from a file knows no future in its last second: its own c^d (known) ends
    before the seed does, the rest is the network's. The held pace is the last known plan's
    (character 0: 0.6 m/s, not the 2.6 predicted at the end); with none known, the end's (1)."""
    n_seed, x = 5, np.zeros((2, LAYOUT.n_x), np.float32)
    src = FreeRunning("seed")
    src.start(normaliser(), LAYOUT, 2, n_seed)
    src.fed(0, straight(0.9, 2), known=np.array([True, False]))
    src.fed(1, straight(0.6, 2), known=np.array([True, False]))   # character 0's last own plan
    src.fed(2, straight(2.6, 2), known=np.array([False, False]))
    assert src.speed is None
    src.fed(3, straight(2.6, 2), known=np.array([False, False]))  # the seed's last frame: predicted
    np.testing.assert_allclose(src.speed, [0.6, 2.6], rtol=1e-6)


def test_steered_turns_left_for_plus_one_and_sets_the_speed():
    """+1 bends the predicted plan to the character's left (+X), by h 0.015 i / 5 at point i;
    -1 to the right; a speed rescales it; per character in a batch."""
    src = Steered([1.0, 2.0])
    src.start(normaliser(), LAYOUT, 2, 2)
    x, pred = np.zeros((2, LAYOUT.n_x), np.float32), straight(1.2, 2)
    src.set(turn=np.array([1.0, -1.0]))
    c = src.next(5, x, pred).reshape(2, 6, 2)
    np.testing.assert_allclose(c[0, :, 0], 0.015 * np.arange(6) / 5, atol=1e-7)
    np.testing.assert_allclose(c[1, :, 0], -0.03 * np.arange(6) / 5, atol=1e-7)
    np.testing.assert_allclose(c[:, :, 1], pred.reshape(2, 6, 2)[:, :, 1])
    np.testing.assert_array_equal(src.raw, c.reshape(2, 12))   # raw = normalised here (identity)
    src.set(0.0, 3.0)
    np.testing.assert_allclose(path_speed(src.next(6, x, pred)), [3.0, 3.0], rtol=1e-6)
    src.set()                                                  # no keys: the prediction itself
    np.testing.assert_array_equal(src.next(7, x, pred), pred)


def test_run_with_a_source_object_equals_the_old_keywords(ds):
    """run(controls=ClipControls(traj)) is run(traj=traj) exactly, PathControls is path=...; a
    source and a keyword together are refused."""
    from data_prep import zoo
    from mocapviz.tasks.generate import Generator
    model, norm, _ = zoo.load("ccnet_default", retrain_if_missing=False)
    a = ds.clip_arrays(ds.clip_row("35_01"))
    x, traj, skel = a["x"][None, :40], a["traj"][None, :40], a["skel"][None]
    types = one_hot([a["type_index"]], model.cfg.n_types)
    clip = a["traj"][None, :70]
    run = lambda **kw: Generator(model, norm).run(x, skel, types, 50, seed_traj=traj, **kw).x_norm  # noqa: E731
    by_clip = run(controls=ClipControls(clip))
    np.testing.assert_array_equal(by_clip, run(traj=clip))
    assert not np.array_equal(by_clip, run())              # the clip's c^d is not the network's own
    path = np.cumsum(np.full((1, 90, 2), 0.02), 1)
    start = dict(start_root=np.array([[0.0, 0.9, 0.0]]), start_heading=np.array([0.5]))
    np.testing.assert_array_equal(run(controls=PathControls(path, *start.values())), run(path=path, **start))
    with pytest.raises(ValueError, match="one control source"):
        run(controls=ClipControls(clip), traj=clip)


def test_the_step_api_is_the_generators_one_path(ds):
    """reset, then advance over the teacher-forced seed and on the network's own c^d, makes
    exactly the frames run() makes free-running."""
    from data_prep import zoo
    from mocapviz.tasks.generate import Generator
    model, norm, _ = zoo.load("ccnet_default", retrain_if_missing=False)
    a = ds.clip_arrays(ds.clip_row("35_01"))
    s, n = 40, 30
    types = one_hot([a["type_index"]], model.cfg.n_types).astype(np.float32)
    ref = Generator(model, norm).run(a["x"][None, :s], a["skel"][None], types, n, seed_traj=a["traj"][None, :s])
    g = Generator(model, norm)
    g.reset(norm.norm_skel(a["skel"][None]), types)
    assert g.type_index.tolist() == [a["type_index"]]
    frames, seed_c = list(norm.norm_x(a["x"][:s])), norm.norm_traj(a["traj"][:s])
    for t in range(s - 1):
        frame, pred = g.advance(frames[t][None], seed_c[t + 1][None], t, write=False)
        assert frame is None
    for t in range(s - 1, s + n - 1):
        frame, pred = g.advance(frames[t][None], pred, t)
        frames.append(frame[0])
    np.testing.assert_array_equal(np.stack(frames), ref.x_norm[0])
    assert pred.shape == (1, model.cfg.n_traj)
