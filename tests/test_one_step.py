"""One-step prediction against the trivial predictors (mocapviz.tasks.one_step), on hand cases
and on real clips with a stub network whose mean is its input."""

import numpy as np
import pytest
import torch

from mocapviz.tasks.one_step import one_step_errors, one_step_table


def test_one_step_errors_by_hand():
    # a ramp of slope 0.1 per frame, then a kink: copy-last errs by the slope, extrapolation
    # only at the kink
    x = np.array([[0.0], [0.1], [0.2], [0.3], [0.1]])
    mean = np.array([[0.1], [0.25], [0.3], [0.0]])   # predictions of frames 1..4
    sigma = np.array([[1.0], [2.0], [3.0], [4.0]])
    e = one_step_errors(x, mean, sigma)
    np.testing.assert_allclose(e["copy_last"][:, 0], [0.1, 0.1, 0.2])
    np.testing.assert_allclose(e["extrapolate"][:, 0], [0.0, 0.0, 0.3], atol=1e-12)
    np.testing.assert_allclose(e["mean_error"][:, 0], [0.05, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(e["sigma"][:, 0], [2.0, 3.0, 4.0])


class CopyLast(torch.nn.Module):
    """A stub network: its mean of frame t+1 is its input frame t, sigma 0.5 everywhere."""

    def __init__(self, n_continuous: int, n_types: int):
        super().__init__()
        self.n, self.cfg = n_continuous, type("Cfg", (), {"n_types": n_types, "phase": False})

    def forward(self, x, skel, traj, types):
        mean = x[..., :self.n]
        return dict(mean=mean, sigma=torch.full_like(mean, 0.5))


def test_a_network_that_copies_its_input_scores_copy_last(ds):
    norm = ds.normaliser
    rows = np.flatnonzero((ds.clips.split == "test").values)[:3]
    table = one_step_table(CopyLast(len(norm.x_mean), len(ds.motion_types)), norm, ds, rows)
    assert list(table.columns) == ["sigma", "mean_error", "copy_last", "extrapolate"]
    assert {"rot", "pos", "all"} <= set(table.index)
    np.testing.assert_allclose(table["mean_error"], table["copy_last"], rtol=1e-5)
    np.testing.assert_allclose(table["sigma"], 0.5)
    # real motion is smooth at 60 fps: constant velocity predicts the joint angles better than
    # standing still, and a frame moves far less than one training standard deviation
    assert table.loc["rot", "extrapolate"] < table.loc["rot", "copy_last"] < 0.1


def test_root_bias_of_a_network_that_copies_its_input_by_hand(ds):
    """Copying frame t as frame t+1 errs by x_t - x_{t+1}: over a clip's frames that sums to
    x_first - x_last, so a type's mean error is the sum of those over its clips' frame pairs."""
    from mocapviz.tasks.one_step import ROOT_COLUMNS, root_bias_table
    norm = ds.normaliser
    rows = np.flatnonzero((ds.clips.split == "test").values)[:4]
    table = root_bias_table(CopyLast(len(norm.x_mean), len(ds.motion_types)), norm, ds, rows)
    assert list(table.columns) == [*ROOT_COLUMNS, "real_speed"]
    root = ds.layout.x_blocks["root"]
    for t, group in ds.clips.iloc[rows].groupby("type"):
        clips = [ds.clip_arrays(ds.clip_row(c))["x"][:, root] for c in group["clip"]]
        by_hand = sum(x[0] - x[-1] for x in clips) / sum(len(x) - 1 for x in clips)
        np.testing.assert_allclose(table.loc[t, list(ROOT_COLUMNS)], by_hand, atol=1e-5)
        speed = np.concatenate([np.abs(x[1:, 1]) for x in clips]).mean()
        assert table.loc[t, "real_speed"] == pytest.approx(speed)


@pytest.mark.parametrize("name, pushes", [
    ("ccnet_generate", False),           # knots of z, the root decoded without z (root_without_z)
])
def test_root_bias_sees_a_standing_type_pushed_forward(ds, name, pushes):
    """Teacher-forced on training clips of the standing types, the mean root's forward error is
    what a generated waving walks off at (measured: 0.26 m/s for the retired ccnet_phase_lerp_scale,
    whose root read z: docs/experiments.md)."""
    from data_prep import zoo
    from mocapviz.tasks.one_step import root_bias_table
    model, norm, _ = zoo.load(name, retrain_if_missing=False)
    standing = ds.clips.type.isin(["wave", "raise_hand"]) & (ds.clips.split == "train")
    table = root_bias_table(model, norm, ds, np.flatnonzero(standing.values))
    assert (table["real_speed"] < 0.05).all()   # the real clips stand
    if pushes:
        assert (table["forward"] > 0.15).all(), table
    else:
        assert (table["forward"].abs() < 0.05).all(), table


def test_linear_code_residual_by_hand():
    from mocapviz.tasks.one_step import linear_code_residual
    rng = np.random.default_rng(0)
    # two independent unit directions with std 3 and 1 in 4 channels: a 1-number code keeps the
    # first, leaving the second's energy (1 per frame over 4 channels: RMS 1/2); 2 numbers keep all
    n = 20000
    basis = np.array([[1, 1, 1, 1], [1, -1, 1, -1]]) / 2.0
    x = np.stack([3 * rng.standard_normal(n), rng.standard_normal(n)], axis=1) @ basis
    r = linear_code_residual(x, [0, 1, 2])
    assert r[0] == pytest.approx(np.sqrt(10 / 4), rel=0.02)
    assert r[1] == pytest.approx(0.5, rel=0.02)
    assert r[2] == pytest.approx(0.0, abs=1e-9)


def test_drift_table_of_a_network_that_repeats_its_input_is_standing_still(ds):
    """A residual CCNet with a zero decoder predicts x_{t+1} = x_t: free-running, it stands
    still at the last true frame, so both columns agree; with the decoder's bias it drifts by
    exactly depth x bias."""
    from mocapviz.models.ccnet import CCNet
    from mocapviz.models.ccnet_config import make_config
    from mocapviz.tasks.one_step import drift_table
    from mocapviz.training.windows import WindowData
    data = WindowData(ds, 40)
    lay = ds.layout
    cfg = make_config("quick", n_x=lay.n_x, n_skel=lay.n_skel, n_traj=lay.n_traj, n_types=lay.n_types,
                      dilations=(1, 2), residual=True)
    model = CCNet(cfg).eval()
    with torch.no_grad():
        model.decoder.weight.zero_()
        model.decoder.bias.zero_()
    pairs = data.train[:8]
    t = drift_table(model, data, pairs, start=20, depths=(1, 5, 19))
    assert list(t.index) == [1, 5, 19] and list(t.columns) == ["free_running", "stand_still"]
    np.testing.assert_allclose(t["free_running"], t["stand_still"], rtol=1e-5)
    assert t["stand_still"].is_monotonic_increasing and t.loc[1, "stand_still"] > 0
    with torch.no_grad():
        model.decoder.bias[cfg.output_slices["mean"]] = 0.01
    drift = drift_table(model, data, pairs, start=20, depths=(1, 5, 19))
    # each free frame adds 0.01 to every channel: at depth d the error is |x_19 + 0.01 d - x_{19+d}|
    b = data.batch(pairs)
    rot = lay.x_blocks["rot"]
    truth = b["x"][:, :, rot][..., b["varying"][rot]]
    expect = [float((truth[:, 19] + 0.01 * d - truth[:, 19 + d]).abs().median()) for d in (1, 5, 19)]
    np.testing.assert_allclose(drift["free_running"], expect, rtol=1e-4)
    assert drift.loc[19, "free_running"] > t.loc[19, "free_running"]
    with pytest.raises(ValueError, match="cannot reach"):
        drift_table(model, data, pairs, start=30, depths=(19,))
