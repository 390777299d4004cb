"""The committed application tables (CCNet Table 1 and trajectory following): columns, every
model, every noise level and dataset; and the seed thinning of quick mode."""

from pathlib import Path

import numpy as np
import pandas as pd

from data_prep.apps_tables import NOISE_STDS, thin

RESULTS = Path(__file__).resolve().parent.parent / "results"


def test_denoising_table_has_every_model_dataset_and_noise():
    t = pd.read_csv(RESULTS / "ccnet_table1_denoising.csv")
    assert list(t.columns) == ["dataset", "noise_std", "model", "mean", "std", "n", "mode", "command"]
    assert set(t["mode"]) == {"full"} and t.command.str.startswith("python -m data_prep apps-tables").all()
    models = set(t.model)
    assert {"ccnet_paper", "ccnet_generate", "erd_quick", "dae_lstm_quick",
            "copy_last", "constant_velocity", "noisy_input"} <= models
    assert any(m.startswith("causal_smoother(k=") for m in models)
    assert set(t.dataset) == {"D", "S-CMU"}
    t["model"] = t.model.str.replace(r"causal_smoother\(.*\)", "causal_smoother", regex=True)
    for (dataset, model), g in t.groupby(["dataset", "model"]):
        assert sorted(g.noise_std) == sorted(NOISE_STDS), (dataset, model)
    assert (t.n > 0).all() and (t["std"] >= 0).all() and (t["mean"] > 0).all()
    # the noisy input's error is the noise: std * sqrt(channels), the same on both datasets
    noisy = t[t.model == "noisy_input"].set_index(["dataset", "noise_std"])["mean"]
    np.testing.assert_allclose(noisy.loc["D"].values, noisy.loc["S-CMU"].values, rtol=0.02)
    # copying the last noisy frame errs more the more noise there is (it carries all of it)
    copy = t[(t.model == "copy_last") & (t.dataset == "D")].sort_values("noise_std")["mean"].values
    assert np.all(np.diff(copy) > 0)


def test_completion_table_reports_the_held_out_leg_before_and_after():
    t = pd.read_csv(RESULTS / "ccnet_completion_tr.csv")
    assert list(t.columns) == ["model", "clips", "frames", "corrupted_cm", "completed_cm", "mode", "command"]
    assert {"ccnet_paper", "copy_last", "constant_velocity"} <= set(t.model)
    assert (t.clips >= 5).all() and t.frames.nunique() == 1
    assert t.corrupted_cm.nunique() == 1     # every model repairs the same corrupted frames


def test_trajectory_table_has_every_model_and_standing_still():
    t = pd.read_csv(RESULTS / "ccnet_trajectory_following.csv")
    assert list(t.columns) == ["model", "mean_cm", "std_cm", "n", "covered", "timed_cm", "timed_std_cm", "mode",
                               "command"]
    assert {"ccnet_generate", "pfnn_quick", "erd_quick", "stand_still"} <= set(t.model)
    moving = t[t.model != "stand_still"]
    assert (t.n > 0).all() and (moving.mean_cm > 0).all() and t.covered.between(0, 1).all()
    assert t.n.nunique() == 1   # every model from the same seeds along the same paths
    still = t.set_index("model").loc["stand_still"]
    assert still.mean_cm < 1.0   # the paper's measure: standing where the path starts is on it
    assert still.covered < 0.2 and still.timed_cm > still.mean_cm


def test_thin_keeps_first_last_and_spreads():
    assert thin(list(range(10)), 4) == [0, 3, 6, 9]
    assert thin([5, 6], 8) == [5, 6]


def test_one_step_table_puts_the_next_frame_model_below_copying_the_last_frame():
    t = pd.read_csv(RESULTS / "ccnet_one_step.csv")
    assert set(t.split) == {"val", "test"} and set(t.block) == {"rot", "angvel", "pos", "vel", "root", "all"}
    nf = t[t.model == "ccnet_paper"].set_index(["split", "block"])
    for split in ("val", "test"):
        for block in ("rot", "pos", "all"):
            assert nf.loc[(split, block), "mean_error"] < nf.loc[(split, block), "copy_last"], (split, block)
    # the paper's network without deviations does not track its input
    default = t[(t.model == "ccnet_default") & (t.block == "all")]
    assert (default.mean_error > 3 * default.copy_last).all()


def test_seed_length_table_has_every_length_and_model():
    t = pd.read_csv(RESULTS / "ccnet_table7_seed_length.csv")
    assert sorted(t.seed_frames.unique()) == [1, 5, 10, 30, 60, 120]
    assert {"ccnet_paper", "erd_quick", "dae_lstm_quick", "copy_last"} <= set(t.model)
    assert t.n.nunique() == 1 and (t.rel_p > 0).all()
    copy = t[t.model == "copy_last"].rel_p
    assert copy.nunique() == 1     # copying the last frame does not depend on the seed's length
