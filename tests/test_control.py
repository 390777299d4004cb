"""Interactive control (paper §4.4): the key semantics by hand, and a scripted session of the
committed CCNets that take the keys (every one) and turn, speed up and change type when asked (those that follow)."""

import functools

import numpy as np
import pytest

from mocapviz.features.motion_types import MOTION_TYPES, one_hot
from mocapviz.tasks.control import (
    BLEND_FRAMES,
    SPEED_STEP,
    ControlSession,
    KeyEvent,
    hold,
    path_speed,
    plan_controls,
    steer,
)

WALK, JOG = MOTION_TYPES.index("walk"), MOTION_TYPES.index("jog")
N_TYPES = len(MOTION_TYPES)
# every committed CCNet that control must drive: the paper's architecture on dataset v4's 21
# types, the generate command's model (a phase, a latent z with a type prior: its c^d is 14 wide)
# and the paper's next-frame network (a residual mean)
CONTROL_MODELS = ("ccnet_default", "ccnet_generate", "ccnet_paper")
# ... and the ones whose character follows the keys; ccnet_paper takes them (the fed c^d bend and
# speed up as asked) but its character does not follow: over 5 seeds and 2 s it turned -0.43 rad
# with left held and +2.05 rad with right held (none: -0.61), rolled out far from its training inputs
FOLLOWING = [pytest.param(m, marks=pytest.mark.xfail(strict=True, reason="ccnet_paper's character does not follow "
                                                    "the keys it takes (test_control.py: FOLLOWING)"))
             if m == "ccnet_paper" else m for m in CONTROL_MODELS]


def test_number_key_blends_the_label_over_20_frames():
    plan = plan_controls([KeyEvent(10, "2")], 60, WALK, N_TYPES)
    assert np.array_equal(plan.types[9], np.eye(N_TYPES)[WALK])
    assert plan.types[10, JOG] == pytest.approx(1 / 20) and plan.types[10, WALK] == pytest.approx(19 / 20)
    assert plan.types[19, JOG] == pytest.approx(0.5)
    assert np.allclose(plan.types[10 + BLEND_FRAMES - 1:], np.eye(N_TYPES)[JOG])
    assert np.allclose(plan.types.sum(1), 1.0)
    assert np.isnan(plan.speed).all() and not plan.turn.any()


def test_up_down_move_the_requested_speed_over_20_frames():
    plan = plan_controls([KeyEvent(5, "up"), KeyEvent(40, "down"), KeyEvent(41, "down"), KeyEvent(42, "down")],
                         100, WALK, N_TYPES, start_speed=1.0)
    assert np.isnan(plan.speed[:5]).all()                 # no request yet: the model's own speed
    assert plan.speed[5] == pytest.approx(1.0 + SPEED_STEP / 20)
    assert plan.speed[24] == pytest.approx(1.5) and plan.speed[39] == pytest.approx(1.5)
    # three downs from 1.5: 1.0, 0.5, 0.0, each ramp starting where the last one had got to
    assert plan.speed[-1] == pytest.approx(0.0) and np.all(np.diff(plan.speed[40:]) <= 1e-12)


def test_steer_turn_offsets_and_speed_by_hand():
    straight = np.stack([np.zeros(6), 0.2 * np.arange(1, 7)], 1).reshape(-1)   # 1.2 m ahead in 1 s
    assert path_speed(straight) == pytest.approx(1.2)
    left = steer(straight, 1.0, np.nan, root_height=1.0).reshape(6, 2)
    assert np.allclose(left[:, 0], 0.015 * np.arange(6) / 5) and np.allclose(left[:, 1], straight[1::2])
    right = steer(straight, -1.0, np.nan, root_height=2.0).reshape(6, 2)
    assert np.allclose(right[:, 0], -0.03 * np.arange(6) / 5)
    fast = steer(straight, 0.0, 3.0, root_height=1.0)
    assert path_speed(fast) == pytest.approx(3.0) and np.allclose(fast, straight * 2.5)
    bent = steer(straight, 1.0, 2.0, root_height=1.0)
    assert path_speed(bent) == pytest.approx(2.0, rel=1e-5)
    assert np.allclose(steer(np.zeros(12), 0.0, 1.5, 1.0).reshape(6, 2)[:, 1], 1.5 * np.arange(1, 7) / 6)


@functools.cache
def load(name):
    from data_prep.sources import REPO_ROOT
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.zoo import find_checkpoint
    return load_checkpoint(find_checkpoint(name, cwd=REPO_ROOT))


@pytest.fixture(scope="module", params=CONTROL_MODELS)
def committed(request):
    return load(request.param)


@pytest.fixture(scope="module")
def seeds(ds):
    """120 seed frames of every locomotion test clip of the quick dataset (5 Bandai takes)."""
    c = ds.clips
    rows = np.flatnonzero((c.split == "test") & c.type.isin(["walk", "jog", "dash"]) & (c.stop - c.start > 130))
    assert len(rows) >= 3
    return [ds.clip_arrays(i) for i in rows]


def session(committed, a, seed_frames=120):
    model, norm, _ = committed
    return ControlSession(model, norm, a["x"][:seed_frames], a["traj"][:seed_frames], a["skel"],
                          one_hot(a["type_index"], model.cfg.n_types))


def scripted(committed, a, events, frames=240):
    s = session(committed, a)
    plan = plan_controls(events, frames, a["type_index"], committed[0].cfg.n_types,
                         start_speed=float(path_speed(s.predicted_traj())))
    s.run(plan)
    path = s.root_path()[0][s.n_seed - 1:, [0, 2]]
    d0, d1 = path[30] - path[0], path[-1] - path[-31]
    turn = np.angle(np.exp(1j * (np.arctan2(d1[0], d1[1]) - np.arctan2(d0[0], d0[1]))))   # + = left
    speed = np.linalg.norm(np.diff(path[len(path) // 2:], axis=0), axis=1).mean() * 60      # m/s, second half
    return s, turn, speed, plan


def test_without_keys_the_session_is_the_free_running_generator(committed, seeds):
    from mocapviz.tasks.generate import Generator
    model, norm, _ = committed
    a = seeds[0]
    s = session(committed, a)
    s.run(plan_controls([], 60, a["type_index"], model.cfg.n_types))
    ref = Generator(model, norm, backend="numpy").run(a["x"][None, :120], a["skel"][None],
                                                      one_hot([a["type_index"]], model.cfg.n_types), 60,
                                                      seed_traj=a["traj"][None, :120])
    assert np.allclose(s.x(), ref.x[0], atol=1e-3)


_RUNS = {}


def scripted_runs(name, seeds):
    """Scripted sessions of the model ``name`` on every seed: no keys, left or right held for 2 s,
    three ups; with the mean turn and speed of the generated root paths per script."""
    if name not in _RUNS:
        committed = load(name)
        runs = {k: [scripted(committed, a, ev) for a in seeds] for k, ev in
                dict(none=[], left=hold("left", 0, 120), right=hold("right", 0, 120),
                     up=[KeyEvent(i, "up") for i in range(3)]).items()}
        turn = {k: np.mean([r[1] for r in v]) for k, v in runs.items()}
        speed = {k: np.mean([r[2] for r in v]) for k, v in runs.items()}
        _RUNS[name] = runs, turn, speed
    return _RUNS[name]


@pytest.mark.parametrize("name", CONTROL_MODELS)
def test_scripted_keys_bend_the_fed_controls_and_change_type(name, seeds):
    runs, _, _ = scripted_runs(name, seeds)
    committed = load(name)
    # the controls themselves: holding left bends every fed c^d to the character's left (+X)
    for (s_left, *_), (s_none, *_) in zip(runs["left"], runs["none"]):
        assert np.mean(np.stack(s_left.controls[:120]).reshape(-1, 6, 2)[:, -1, 0]) > \
            np.mean(np.stack(s_none.controls[:120]).reshape(-1, 6, 2)[:, -1, 0])
    for s_up, _, _, plan in runs["up"]:   # ... and "up" makes every fed c^d as fast as requested
        assert np.allclose(path_speed(np.stack(s_up.controls)), plan.speed, rtol=1e-4)
    # type: "2" after a walk seed blends to jog, and the generator receives it
    walk_seed = next(a for a in seeds if a["type_index"] == WALK)
    s, *_ = scripted(committed, walk_seed, [KeyEvent(30, "2")], frames=80)
    assert np.array_equal(s.types, one_hot(JOG, committed[0].cfg.n_types))


@pytest.mark.parametrize("name", FOLLOWING)
def test_scripted_keys_steer_the_character(name, seeds):
    _, turn, speed = scripted_runs(name, seeds)
    # the generated root paths (5 seeds, mean): left turns more to the left than right does, and
    # three ups (+1.5 m/s requested) make the character faster
    assert turn["left"] - turn["right"] > 0.5, turn
    assert turn["left"] > turn["none"], turn
    assert speed["up"] - speed["none"] > 0.5, speed
