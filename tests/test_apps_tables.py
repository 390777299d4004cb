"""The committed application tables (CCNet Table 1 and trajectory following): columns, every
model, every noise level and dataset; and the seed thinning of quick mode."""

from pathlib import Path

import numpy as np
import pandas as pd

from data_prep.apps_tables import NOISE_STDS, thin

RESULTS = Path(__file__).resolve().parent.parent / "results"


def test_denoising_table_has_every_model_dataset_and_noise():
    t = pd.read_csv(RESULTS / "ccnet_table1_denoising.csv")
    assert list(t.columns) == ["dataset", "noise_std", "model", "mean", "std", "n"]
    assert {"ccnet_wide", "erd_quick", "dae_lstm_quick", "noisy_input"} <= set(t.model)
    assert set(t.dataset) == {"D", "S-CMU"}
    for (dataset, model), g in t.groupby(["dataset", "model"]):
        assert sorted(g.noise_std) == sorted(NOISE_STDS), (dataset, model)
    assert (t.n > 0).all() and (t["std"] >= 0).all() and (t["mean"] > 0).all()
    # the noisy input's error is the noise: std * sqrt(channels), the same on both datasets
    noisy = t[t.model == "noisy_input"].set_index(["dataset", "noise_std"])["mean"]
    np.testing.assert_allclose(noisy.loc["D"].values, noisy.loc["S-CMU"].values, rtol=0.02)


def test_trajectory_table_has_the_three_models():
    t = pd.read_csv(RESULTS / "ccnet_trajectory_following.csv")
    assert list(t.columns) == ["model", "mean_cm", "std_cm", "n", "covered"]
    assert {"ccnet_wide", "pfnn_quick", "erd_quick"} <= set(t.model)
    assert (t.n > 0).all() and (t.mean_cm > 0).all() and t.covered.between(0, 1).all()
    assert t.n.nunique() == 1   # every model from the same seeds along the same paths


def test_thin_keeps_first_last_and_spreads():
    assert thin(list(range(10)), 4) == [0, 3, 6, 9]
    assert thin([5, 6], 8) == [5, 6]
