"""CCNet's ablation settings (paper §4.8): hidden inputs, the evaluation window, the runs' CRLs."""

from __future__ import annotations

import csv
from dataclasses import replace

import numpy as np
import pytest
import torch

from data_prep.ccnet_ablations import ablations, config_of, receptive_field
from mocapviz.training.config import TRAIN_CONFIGS, TrainConfig
from mocapviz.training.trainer import evaluate, train
from mocapviz.training.windows import WindowData


def test_receptive_fields_of_the_paper_runs():
    # Eq. 3 with k = 2: CRL = 1 + sum of the dilations; the paper's 31, 41 and 46
    assert receptive_field((2,) * 20) == 41
    assert {n: receptive_field(config_of(n, 10).dilations) for n in ("reference", "crl31", "crl46")} == \
        {"reference": 41, "crl31": 31, "crl46": 46}
    assert all(len(config_of(n, 10).dilations) == 20 for n in ablations())  # 20 SRBs in every run


def test_each_run_changes_one_setting_of_the_reference():
    ref = config_of("reference", 10)
    for name in ablations():
        if name == "reference":
            continue
        changed = {k for k in ref.__dataclass_fields__ if getattr(config_of(name, 10), k) != getattr(ref, k)}
        assert changed in ({"dilations"}, {"window"}, {"hidden_inputs"}, {"lambdas"}, {"model", "size"}), (name, changed)
        assert config_of(name, 10).eval_window == 240   # every run scored on 240-frame windows


def test_hidden_inputs_are_their_training_mean_in_the_inputs_only(ds):
    pairs = WindowData(ds, 30).train[:4]
    shown = WindowData(ds, 30).batch(pairs)
    b = ds.layout.x_blocks
    no_rot = WindowData(ds, 30, hidden_inputs=("rotations",)).batch(pairs)
    hidden = np.zeros(ds.layout.n_x, bool)
    hidden[b["rot"]] = hidden[b["angvel"]] = True
    assert torch.all(no_rot["x"][..., hidden] == 0) and torch.equal(no_rot["x"][..., ~hidden], shown["x"][..., ~hidden])
    assert shown["x"][..., hidden].abs().sum() > 0
    for key in ("target_x", "skel", "traj", "target_traj"):   # the targets and other inputs are untouched
        assert torch.equal(no_rot[key], shown[key])
    no_sk = WindowData(ds, 30, hidden_inputs=("skeleton",)).batch(pairs)
    assert torch.all(no_sk["skel"] == 0) and shown["skel"].abs().sum() > 0
    assert torch.equal(no_sk["x"], shown["x"])
    with pytest.raises(ValueError, match="cannot hide"):
        WindowData(ds, 30, hidden_inputs=("phase",))


def test_config_with_hidden_inputs_round_trips_through_json():
    cfg = replace(TRAIN_CONFIGS["quick"], hidden_inputs=("rotations", "skeleton"), eval_window=240)
    assert TrainConfig.from_json(cfg.to_json()) == cfg


def test_a_run_is_scored_on_windows_of_eval_window_frames(ds, tmp_path):
    cfg = replace(TRAIN_CONFIGS["quick"], steps=2, eval_every=2, checkpoint_every=2, batch_size=2, window=30,
                  eval_window=90, hidden_inputs=("skeleton",))
    ckpt = train(ds, cfg, tmp_path, progress=False)
    with open(tmp_path / "losses.csv") as f:
        logged = [r for r in csv.DictReader(f) if r["test_nll"]][-1]
    from mocapviz.training.checkpoint import load_checkpoint
    model = load_checkpoint(ckpt)[0]
    data = WindowData(ds, 90, hidden_inputs=("skeleton",))
    assert float(logged["test_nll"]) == pytest.approx(evaluate(model, data, data.test)["nll"], abs=1e-4)
    other = WindowData(ds, 30, hidden_inputs=("skeleton",))   # the training windows score differently
    assert abs(float(logged["test_nll"]) - evaluate(model, other, other.test)["nll"]) > 1e-3


def test_a_run_counts_as_finished_only_at_its_last_step(tmp_path):
    from data_prep.ccnet_ablations import finished
    from mocapviz.training.runs import write_log
    assert not finished(tmp_path, 10)                      # no log yet
    write_log(tmp_path / "losses.csv", [dict(step=s, loss=1.0) for s in range(1, 4)])
    assert not finished(tmp_path, 10) and finished(tmp_path, 3)
