"""4D prediction (paper 2 §5): the Residual-sup baseline, the common clock and the error table."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from mocapviz.bodies.representation import PHI_SCALE
from mocapviz.features.chi_time import time_grid
from mocapviz.models.residual_sup import ResidualSup, ResidualSupConfig
from mocapviz.tasks.cvae4d_prediction import (PredictionSetup, Predictions, error_table, observed_window,
                                              predict_residual)
from mocapviz.training.residual_sup import (ResidualSupTrainConfig, grid_frames, labels_for, load_residual_sup,
                                            masked_mse, n_observed, save_residual_sup, train)


def _model(n_state=3, hidden=8, types=("run", "walk")):
    torch.manual_seed(0)
    return ResidualSup(ResidualSupConfig(n_state=n_state, types=types, hidden=hidden))


def _linear_chi(values_per_s, duration, n=11):
    """chi (1, n, 4): three channels growing linearly in time (rate per second), then Phi."""
    t = torch.linspace(0, duration, n, dtype=torch.float64)
    rate = torch.tensor(values_per_s, dtype=torch.float64)
    return torch.cat([t[:, None] * rate, (t / PHI_SCALE)[:, None]], 1)[None].float()


def test_untrained_model_is_zero_velocity():
    m = _model()
    obs = torch.randn(2, 5, 3)
    out = m(obs, m.one_hot(["walk", "run"]), 4)
    assert out.shape == (2, 4, 3)
    torch.testing.assert_close(out, obs[:, -1:].expand(-1, 4, -1))


def test_residual_output_accumulates_on_its_own_predictions():
    m = _model()
    with torch.no_grad():
        m.out.bias.copy_(torch.tensor([0.1, -0.2, 0.0]))  # W h = bias: a constant change per frame
    obs = torch.zeros(1, 3, 3)
    out = m(obs, m.one_hot(["run"]), 3)
    # each frame adds the change to the previous *prediction*: 1, 2, 3 times it
    np.testing.assert_allclose(out[0].detach().numpy(), [[0.1, -0.2, 0], [0.2, -0.4, 0], [0.3, -0.6, 0]], atol=1e-6)


def test_labels_one_hot_and_fallback():
    m = _model()
    np.testing.assert_array_equal(m.one_hot(["walk", "run"]).numpy(), [[0, 1], [1, 0]])
    np.testing.assert_array_equal(labels_for(m, ["jog", "sneak"]).numpy(), [[1, 0], [0, 1]])  # run, walk
    with pytest.raises(ValueError, match="hop"):
        labels_for(m, ["hop"])


def test_time_grid_and_observed_frames():
    times, mask = time_grid([0.05, 0.02], 100.0)
    np.testing.assert_allclose(times[0].numpy(), [0, 0.01, 0.02, 0.03, 0.04, 0.05], atol=1e-7)
    np.testing.assert_array_equal(mask.numpy(), [[1, 1, 1, 1, 1, 1], [1, 1, 1, 0, 0, 0]])
    assert n_observed(100.0, 0.25) == 25 and n_observed(30.0, 0.25) == 8
    chi = _linear_chi([1.0, 0, 0], 1.0)  # frames every 0.1 s: 0 and 0.1 and 0.2 are before 0.25
    t, m = observed_window(chi, 0.25)
    np.testing.assert_allclose(t[0].numpy(), [0, 0.1, 0.2], atol=1e-6)
    assert bool(m.all())


def test_grid_frames_reads_by_real_timestamps():
    chi = torch.cat([_linear_chi([1.0, 2.0, -1.0], 0.5), _linear_chi([0.0, 1.0, 0.0], 0.3)])
    frames, mask = grid_frames(chi, 100.0)
    assert frames.shape == (2, 51, 3)  # Phi dropped; 0..0.5 s at 100 fps
    t = torch.arange(51) / 100.0
    torch.testing.assert_close(frames[0], t[:, None] * torch.tensor([1.0, 2.0, -1.0]), atol=1e-5, rtol=0)
    assert int(mask[1].sum()) == 31 and int(mask[0].sum()) == 51


def test_predict_residual_keeps_the_observed_frames_and_stamps_time():
    chi = _linear_chi([1.0, 2.0, -1.0], 0.6)
    m = _model(types=("walk",))
    setup = PredictionSetup(observed_s=0.25, fps=100.0)
    out = predict_residual(m, chi, ["walk"], setup)
    assert out.shape == (1, 61, 4)
    frames, _ = grid_frames(chi, 100.0)
    torch.testing.assert_close(out[0, :25, :3], frames[0, :25])
    torch.testing.assert_close(out[0, 25:, :3], frames[0, 24:25].expand(36, -1))  # zero velocity after
    np.testing.assert_allclose(out[0, :, 3].numpy() * PHI_SCALE, np.arange(61) / 100.0, atol=1e-6)


def test_error_table_means_over_cycles_long_enough():
    times, mask = time_grid([0.03, 0.01], 100.0)  # cycle 2 ends at 0.01 s
    err = torch.tensor([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 99.0, 99.0]])  # 99: past its end, not counted
    pred = Predictions(times, mask, None, {}, {}, errors={"m": err})
    tab = error_table(pred, PredictionSetup(observed_s=0.02))
    exp = pd.DataFrame(dict(model="m", t_s=[0.0, 0.01, 0.02, 0.03], mean_mm=[3.0, 4.0, 3.0, 4.0], n=[2, 2, 1, 1],
                            observed=[True, True, False, False]))
    pd.testing.assert_frame_equal(tab, exp, check_dtype=False)


def test_masked_mse():
    pred, target = torch.zeros(1, 2, 2), torch.tensor([[[1.0, 1.0], [5.0, 5.0]]])
    assert float(masked_mse(pred, target, torch.tensor([[True, False]]))) == pytest.approx(1.0)


class _TinyDataset:
    """Two cycles, one per type, each a steady drift: what train() reads (chi, cycles.type)."""

    def __init__(self):
        self.chi = torch.cat([_linear_chi([0.5, 0, 0], 0.5, 51), _linear_chi([0, -0.5, 0], 0.5, 51)]).numpy()
        self.cycles = pd.DataFrame(dict(type=["walk", "run"]))


def test_training_learns_a_drift_and_round_trips(tmp_path):
    ds = _TinyDataset()
    cfg = ResidualSupTrainConfig(hidden=8, steps=150, batch_size=2, lr=1e-2, observed_s=0.1, eval_every=150)
    model, rows = train(ds, cfg, np.array([0, 1]), np.array([0, 1]), progress=False)
    assert rows[-1]["held_loss"] < 0.05 * rows[0]["loss"]  # zero velocity is the starting point
    save_residual_sup(tmp_path / "r.safetensors", model, dict(note="test"))
    back, meta = load_residual_sup(tmp_path / "r.safetensors")
    assert back.cfg == model.cfg and meta["note"] == "test"
    obs = torch.as_tensor(ds.chi[:, :10, :3])
    labels = model.one_hot(["walk", "run"])
    torch.testing.assert_close(back(obs, labels, 5), model(obs, labels, 5))


def test_ordering_over_predicted_times():
    from mocapviz.tasks.cvae4d_prediction import ordering

    t = [0.0, 0.1, 0.2, 0.3, 0.4]
    tab = pd.concat([pd.DataFrame(dict(model="cvae", t_s=t, mean_mm=[50, 60, 70, 80, 90], n=[3, 3, 3, 3, 1],
                                       observed=[True, False, False, False, False])),
                     pd.DataFrame(dict(model="rs", t_s=t, mean_mm=[0, 40, 75, 100, 10], n=[3, 3, 3, 3, 1],
                                       observed=[True, False, False, False, False]))])
    o = ordering(tab, "cvae", "rs", min_n=2)  # t = 0.1, 0.2, 0.3: above, below, below
    assert o["n_times"] == 3 and o["share_below"] == pytest.approx(2 / 3)
    assert o["mean_ours"] == pytest.approx(70) and o["mean_baseline"] == pytest.approx(215 / 3)
    assert o["first_t_below"] == pytest.approx(0.2) and o["last_t_below"] == pytest.approx(0.3)
    assert o["crossings"] == [pytest.approx(0.2)]
    assert ordering(tab, "cvae", "rs")["crossings"] == [pytest.approx(0.2), pytest.approx(0.4)]


REPO = __import__("pathlib").Path(__file__).resolve().parent.parent


def test_committed_table_and_baseline():
    from mocapviz.zoo import load_residual_sup

    tab = pd.read_csv(REPO / "results" / "cvae4d_prediction.csv")
    assert list(tab.columns) == ["model", "t_s", "mean_mm", "n", "observed"]
    assert set(tab["model"]) == {"cvae4d_phase2", "residual_sup"}
    for _, g in tab.groupby("model"):
        assert np.all(np.diff(g["t_s"]) > 0) and np.all(np.diff(g["n"]) <= 0)  # fewer cycles as t grows
        np.testing.assert_array_equal(g["observed"], g["t_s"] < 0.25 - 1e-9)
    rs = tab[tab["model"] == "residual_sup"]
    assert (rs.loc[rs["observed"], "mean_mm"] == 0).all()  # its input
    assert (rs.loc[~rs["observed"], "mean_mm"] > 0).all()
    model, meta = load_residual_sup("residual_sup", REPO / "models" / "zoo")
    assert meta["train_config"]["hidden"] == model.cfg.hidden and meta["command"].startswith("python -m data_prep")
