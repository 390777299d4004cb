"""The predictors that do nothing (copy-last, constant velocity, causal smoother) on hand-made
cases, and the time budget of the trainer."""

import time

import numpy as np
import pytest

from mocapviz.tasks import do_nothing as dn
from mocapviz.tasks.denoising import denoising_errors
from mocapviz.training.trainer import StepBudget


class Ref:
    """A reference normaliser with three continuous channels (x_mean's length), the middle one
    constant."""
    x_mean = np.zeros(3)
    x_std = np.ones(3)

    def constant_channels(self):
        return np.array([False, True, False])

    def norm_x(self, x):
        return np.asarray(x, np.float32)


def test_extrapolation_weights_by_hand():
    np.testing.assert_allclose(dn.extrapolation_weights(2, 1), [-1.0, 2.0], atol=1e-12)      # 2 x_t - x_{t-1}
    np.testing.assert_allclose(dn.extrapolation_weights(3, 2), [1.0, -3.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(dn.extrapolation_weights(4, 0), [0.25] * 4, atol=1e-12)      # the mean
    # least squares line through (-2, 0), (-1, 1), (0, 1) evaluated at 1: slope 0.5, value 1 2/3 + 0.5
    w = dn.extrapolation_weights(3, 1)
    assert w @ np.array([0.0, 1.0, 1.0]) == pytest.approx(2.0 / 3.0 + 0.5 + 0.5)


def test_each_predictor_is_exact_on_the_motion_it_assumes():
    t = np.arange(20.0)
    x = np.stack([t ** 2, 3.0 + 0 * t, 2 * t], 1)   # quadratic, still, linear
    nxt = np.vstack([x[1:], [[20.0 ** 2, 3.0, 40.0]]])
    copy = dn.CopyLast(Ref()).predict(x)
    cv = dn.ConstantVelocity(Ref()).predict(x)
    quad = dn.CausalSmoother(Ref(), 5, 2).predict(x)
    np.testing.assert_allclose(copy[:, 1], nxt[:, 1])             # still: copy is exact
    np.testing.assert_allclose(cv[1:, 2], nxt[1:, 2])             # linear: constant velocity is exact
    assert np.abs(cv[1:, 0] - nxt[1:, 0]).max() == pytest.approx(2.0)   # ... but errs 2 on t^2
    np.testing.assert_allclose(quad[4:], nxt[4:], atol=1e-9)      # degree 2 through 5 frames: exact
    # the first frames use what exists: frame 0 alone is copied
    np.testing.assert_allclose(quad[0], x[0])


def test_repair_aligns_frame_t_plus_1_with_frames_up_to_t():
    x = np.random.default_rng(0).standard_normal((30, 5))   # 3 continuous + 2 contact channels
    out = dn.CopyLast(Ref()).repair(x)
    assert out.shape == (29, 3)
    np.testing.assert_allclose(out, x[:-1, :3], atol=1e-6)


def test_smoother_beats_copy_last_on_noisy_motion_and_averages_more_under_more_noise():
    t = np.linspace(0, 40, 400)
    x = np.stack([np.sin(t), np.zeros_like(t), np.cos(t), np.zeros_like(t), np.zeros_like(t)], 1)
    clips = [dict(x=x, traj=None, skel=None, type_index=0)]
    low, low_scores = dn.choose_smoother(Ref(), clips, 0.01)
    high, _ = dn.choose_smoother(Ref(), clips, 0.3)
    def noise_gain(s):   # how much of i.i.d. input noise the filter passes (sum of squared weights)
        return float(np.sum(dn.extrapolation_weights(s.k, s.degree) ** 2))
    assert noise_gain(high) < 0.5 * noise_gain(low)   # more noise: a longer, flatter average
    errs = denoising_errors({"copy": dn.CopyLast(Ref())}, clips, [0.3], per_noise=lambda s: {"smooth": high})
    assert errs[(0.3, "smooth")].mean() < 0.8 * errs[(0.3, "copy")].mean()
    assert min(low_scores.values()) == low_scores[(low.k, low.degree)]


def test_step_budget_turns_minutes_into_steps_once():
    b = StepBudget(minutes=0.01, start=0, warmup=1, measure=4)   # 0.6 s
    got = []
    for step in range(6):
        got.append(b.steps(step))
        time.sleep(0.01)
    assert got[:5] == [None] * 5 and b.decided
    # 4 steps of ~10 ms measured; about 0.95 * (0.6 - 0.06) / 0.01 = ~51 more steps
    assert 20 < got[5] - 5 < 60
    assert b.steps(6) is None
    time.sleep(0.6)
    assert b.overrun(7, 100) == 8 and b.overrun(7, 8) is None


def test_seed_length_table_by_hand():
    from mocapviz.tasks.seed_length import predicted_frames, seed_length_table
    t = np.arange(200.0)
    x = np.stack([10 + t, np.full_like(t, 3.0), 20 - 0.05 * t, np.zeros_like(t), np.zeros_like(t)], 1)
    clip = dict(x=x, traj=np.zeros((200, 12)), skel=None, type_index=0)
    assert [p for _, p in predicted_frames([clip], 120, every=30)] == [120, 150, 180]
    table = seed_length_table({"copy": dn.CopyLast(Ref()), "cv": dn.ConstantVelocity(Ref())}, [clip],
                              lengths=(1, 2, 120), every=30).set_index(["model", "seed_frames"])
    # copying the last frame errs by one frame's change whatever the seed: |(1, 0, -0.05)| / |x_p|
    expected = np.mean([np.hypot(1, 0.05) / np.linalg.norm(x[p, :3]) for p in (120, 150, 180)])
    for length in (1, 2, 120):
        assert table.loc[("copy", length), "rel_p"] == pytest.approx(expected)
    # constant velocity needs two frames: with one it copies, with two or more it is exact on a line
    assert table.loc[("cv", 1), "rel_p"] == pytest.approx(expected)
    assert table.loc[("cv", 2), "rel_p"] < 1e-6 and table.loc[("cv", 120), "rel_p"] < 1e-6
    assert (table.n == 3).all()
