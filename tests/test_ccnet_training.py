"""CCNet training: the optimiser fits one clip, exact resume, best-by-validation selection and export,
checkpoint contents, DDP (slow)."""

import csv
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from mocapviz.models.ccnet import CCNet
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.training.config import TRAIN_CONFIGS
from mocapviz.training.runs import best_row, export_model
from mocapviz.training.trainer import train
from mocapviz.training.windows import WindowData

TINY = replace(TRAIN_CONFIGS["quick"], steps=8, batch_size=4, window=30, eval_every=4, checkpoint_every=4,
               dilations=(1, 2, 4))


def test_quick_optimiser_fits_one_clip_better_than_copying_the_frame(ds):
    """The "quick" config's network (20 blocks, dropout off) and optimiser at its lr fit 4 windows
    of one training clip, teacher-forced, within 200 steps: the mean's RMS error (normalised,
    varying channels) falls below copying the current frame. torch's RMSprop at lr 1e-3 did not
    (no bias correction: ~10x lr steps at the start). On the quick v4 dataset's most moving
    training clip: copy 1.43, Adam 0.32, RMSprop 1e-3 1.48."""
    cfg = replace(TRAIN_CONFIGS["quick"], dropout=0.0)
    data = WindowData(ds, cfg.window)
    clips = data.train[:, 0]
    n = ds.layout.n_continuous

    def copy_error(b):
        return (b["x"][..., :n] - b["target_x"][..., :n])[..., b["varying"]].pow(2).mean().item()
    # the training clip that moves most (a near-static clip is copied almost exactly, nothing to learn)
    batches = [data.batch(data.train[clips == c][:4]) for c in np.unique(clips) if (clips == c).sum() >= 4]
    b = max(batches, key=copy_error)
    torch.manual_seed(0)
    model = CCNet(cfg.model_config(data.layout))
    var = b["varying"]
    target = b["target_x"][..., :n][..., var]
    opt = cfg.make_optimizer(model.parameters())
    for _ in range(200):
        loss = (model(b["x"], b["skel"], b["traj"], b["types"])["mean"][..., var] - target).pow(2).sum(-1).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    model.eval()
    with torch.no_grad():
        mean = model(b["x"], b["skel"], b["traj"], b["types"])["mean"][..., var]
    rms = lambda a: a.pow(2).mean().sqrt().item()
    assert rms(mean - target) < rms(b["x"][..., :n][..., var] - target)


def rows(path):
    with open(path / "losses.csv", newline="") as f:
        return [{k: v for k, v in r.items() if k != "seconds"} for r in csv.DictReader(f)]


def test_resume_continues_the_same_loss_curve(ds, tmp_path):
    full = train(ds, TINY, tmp_path / "full", progress=False)
    part = train(ds, TINY, tmp_path / "part", progress=False, stop_after=4)
    assert load_checkpoint(part)[2]["step"] == 4 and len(rows(tmp_path / "part")) == 4
    resumed = train(ds, TINY, tmp_path / "part", progress=False)
    a, b = rows(tmp_path / "full"), rows(tmp_path / "part")
    assert len(a) == len(b) == 8
    assert a == b  # every loss term and the test NLL, to the printed digits
    m1, _, _ = load_checkpoint(full)
    m2, _, _ = load_checkpoint(resumed)
    for (k, v1), v2 in zip(m1.state_dict().items(), m2.state_dict().values()):
        assert torch.equal(v1, v2), k
    # losses change from step to step (the run is not a no-op)
    assert len({r["loss"] for r in a}) > 4
    # validation and test NLL are logged at the eval steps only
    assert [r["step"] for r in a if r["val_nll"]] == [r["step"] for r in a if r["test_nll"]] == ["4", "8"]
    # the best-by-validation model is the same whether or not the run was interrupted
    best = best_row(a)
    assert float(best["val_nll"]) == min(float(r["val_nll"]) for r in a if r["val_nll"])
    b1, _, meta1 = load_checkpoint(tmp_path / "full" / "best.safetensors")
    b2, _, meta2 = load_checkpoint(tmp_path / "part" / "best.safetensors")
    assert meta1["step"] == meta2["step"] == int(best["step"]) and "optim_param_groups" not in meta1
    for (k, v1), v2 in zip(b1.state_dict().items(), b2.state_dict().values()):
        assert torch.equal(v1, v2), k
    # export takes the best model, records where it came from, and drops nothing else
    _, _, em = load_checkpoint(export_model(tmp_path / "full", tmp_path / "export.safetensors"))
    assert em["step"] == int(best["step"]) and em["final_step"] == 8 and em["selected_by"] == "val_nll"
    assert em["val_nll"] == float(best["val_nll"]) and em["test_nll"] == float(best["test_nll"])


def test_latent_run_trains_logs_the_kl_and_resumes_exactly(ds, tmp_path):
    """A latent CCNet: the same losses whether or not it was interrupted, a positive KL in the
    log, and moving posterior weights."""
    cfg = replace(TINY, latent=4, dropout=0.0)
    full = train(ds, cfg, tmp_path / "full", progress=False)
    train(ds, cfg, tmp_path / "part", progress=False, stop_after=4)
    train(ds, cfg, tmp_path / "part", progress=False)
    a = rows(tmp_path / "full")
    assert a == rows(tmp_path / "part") and all(float(r["kl"]) > 0 for r in a)
    torch.manual_seed(cfg.seed)
    init = CCNet(cfg.model_config(ds.layout))
    trained, _, _ = load_checkpoint(full)
    assert trained.cfg.latent == 4
    assert not torch.equal(init.posterior[0].weight, trained.posterior[0].weight)


def test_body_scale_run_keeps_the_scaled_normaliser_and_resumes_exactly(ds, tmp_path):
    """A run with each window's body scaled (``body_scale``): the checkpoint carries c^s's
    statistics over the scaled bodies (Normaliser.body_scaled), the config survives its JSON,
    the losses are the same whether or not the run was interrupted, and a bad range is refused."""
    from mocapviz.training.config import TrainConfig
    cfg = replace(TINY, body_scale=(0.9, 1.25))
    assert TrainConfig.from_json(cfg.to_json()) == cfg
    full = train(ds, cfg, tmp_path / "full", progress=False)
    train(ds, cfg, tmp_path / "part", progress=False, stop_after=4)
    train(ds, cfg, tmp_path / "part", progress=False)
    assert rows(tmp_path / "full") == rows(tmp_path / "part")
    _, norm, _ = load_checkpoint(full)
    want = ds.normaliser.body_scaled(0.9, 1.25)
    np.testing.assert_array_equal(norm.skel_std, want.skel_std)
    assert norm.skel_std[0] > ds.normaliser.skel_std[0]        # the scaled bodies spread wider
    with pytest.raises(ValueError, match="body_scale"):
        replace(TINY, body_scale=(1.25, 0.9))


def test_resume_restores_the_best_so_far_from_the_log(ds, tmp_path):
    # stop at 6 (not an eval step): nothing extra is evaluated or selected at the interruption
    cfg = replace(TINY, steps=12)
    train(ds, cfg, tmp_path / "full", progress=False)
    train(ds, cfg, tmp_path / "part", progress=False, stop_after=6)
    assert [r["step"] for r in rows(tmp_path / "part") if r["val_nll"]] == ["4"]
    train(ds, cfg, tmp_path / "part", progress=False)
    assert rows(tmp_path / "full") == rows(tmp_path / "part")
    a = load_checkpoint(tmp_path / "full" / "best.safetensors")
    b = load_checkpoint(tmp_path / "part" / "best.safetensors")
    assert a[2]["step"] == b[2]["step"] == int(best_row(rows(tmp_path / "full"))["step"])
    assert all(torch.equal(v, b[0].state_dict()[k]) for k, v in a[0].state_dict().items())
    # the best-so-far value really comes from the log: make step 4 unbeatable there, and the
    # resumed run keeps step 4's best.safetensors (the validation NLL here falls at every eval)
    train(ds, cfg, tmp_path / "tampered", progress=False, stop_after=6)
    log = (tmp_path / "tampered" / "losses.csv").read_text().splitlines()
    head, i = log[0].split(","), next(k for k, line in enumerate(log) if line.startswith("4,"))
    cells = log[i].split(",")
    cells[head.index("val_nll")] = "-1e9"
    log[i] = ",".join(cells)
    (tmp_path / "tampered" / "losses.csv").write_text("\n".join(log) + "\n")
    train(ds, cfg, tmp_path / "tampered", progress=False)
    assert load_checkpoint(tmp_path / "tampered" / "best.safetensors")[2]["step"] == 4
    assert a[2]["step"] != 4


def test_resume_refuses_another_config(ds, tmp_path):
    train(ds, TINY, tmp_path, progress=False, stop_after=4)
    with pytest.raises(ValueError, match="another config"):
        train(ds, replace(TINY, lr=5e-4), tmp_path, progress=False)


def test_zoo_trains_only_when_allowed_and_handed_data(ds, tmp_path):
    from mocapviz import zoo
    with pytest.raises(FileNotFoundError, match="no cached run"):
        zoo.load("ccnet_quick", zoo_dir=None, cache_dir=tmp_path, dataset=ds, retrain_if_missing=False)
    assert not any(tmp_path.iterdir())  # nothing was trained


def test_command_line_trains_and_exports(tmp_path, capsys):
    from data_prep.cli import main
    out = tmp_path / "run"
    assert main(["train", "--config", "quick", "--dataset", "quick", "--steps", "2", "--batch-size", "2",
                 "--eval-every", "2", "--out", str(out), "--export", str(tmp_path / "m.safetensors")]) == 0
    printed = capsys.readouterr().out
    assert "step 2: val NLL" in printed and "best by validation: step 2" in printed
    assert load_checkpoint(tmp_path / "m.safetensors")[2]["step"] == 2 and len(rows(out)) == 2
    assert main(["train", "--config", "huge", "--out", str(out)]) == 2  # unknown config: an error, no traceback


def test_checkpoint_carries_config_and_normaliser(ds, tmp_path):
    ckpt = train(ds, TINY, tmp_path, progress=False, stop_after=4)
    model, norm, meta = load_checkpoint(ckpt)
    assert model.cfg.dilations == (1, 2, 4) and meta["dataset"]["test_subject"] == ds.meta["test_subject"]
    assert (norm.x_mean == ds.normaliser.x_mean).all()
    assert "optim_param_groups" in meta


def free_port() -> int:
    """A TCP port nothing listens on now (a fixed one clashed with other jobs on the machine)."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_torchrun_two_processes_gloo(ds, tmp_path):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node=2", f"--master_port={free_port()}",
           "-m", "data_prep", "train", "--config", "quick", "--dataset", "quick", "--steps", "4", "--batch-size", "4",
           "--eval-every", "2", "--out", str(tmp_path)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900,
                         cwd=Path(__file__).resolve().parent.parent)
    assert res.returncode == 0, res.stderr[-3000:]
    assert len(rows(tmp_path)) == 4  # rank 0 alone wrote the log
    assert load_checkpoint(tmp_path / "checkpoint.safetensors")[2]["step"] == 4


def test_fine_tuning_starts_from_the_pretrained_network_and_its_normaliser(ds, tmp_path):
    pre = train(ds, replace(TINY, steps=4, eval_every=4, checkpoint_every=4), tmp_path / "pre", progress=False)
    pre_model, pre_norm, _ = load_checkpoint(pre)
    # fine-tune on a dataset whose own normaliser differs, one step at a vanishing learning rate:
    # the run must keep the pretrained units and start from the pretrained weights
    other = replace(ds, normaliser=replace(ds.normaliser, x_mean=ds.normaliser.x_mean + 1.0))
    still = replace(TINY, steps=1, eval_every=1, checkpoint_every=1, lr=1e-12, lr_final=1e-12, seed=5)
    tuned = train(other, still, tmp_path / "tuned", progress=False, init=pre)
    model, norm, meta = load_checkpoint(tuned)
    np.testing.assert_array_equal(norm.x_mean, pre_norm.x_mean)
    assert meta["init"] == str(pre) and model.cfg == pre_model.cfg
    for (k, a), b in zip(model.state_dict().items(), pre_model.state_dict().values()):
        torch.testing.assert_close(a, b, atol=1e-6, rtol=0, msg=k)
    # without init the same run starts from fresh weights
    fresh, _, _ = load_checkpoint(train(other, still, tmp_path / "fresh", progress=False))
    assert not torch.allclose(fresh.encoder.weight, pre_model.encoder.weight)


def test_fine_tuning_keeps_dae_lstms_pretrained_autoencoder(ds, tmp_path):
    cfg = replace(TRAIN_CONFIGS["quick"], model="dae_lstm", steps=1, eval_every=1, checkpoint_every=1, batch_size=2,
                  window=30)
    pre = train(ds, cfg, tmp_path / "pre", progress=False)
    pre_model = load_checkpoint(pre)[0]
    tuned = load_checkpoint(train(ds, replace(cfg, seed=3), tmp_path / "tuned", progress=False, init=pre))[0]
    for (k, a), b in zip(tuned.dae_encoder.state_dict().items(), pre_model.dae_encoder.state_dict().values()):
        torch.testing.assert_close(a, b, atol=0, rtol=0, msg=k)   # not pretrained again on the new data
    assert not torch.equal(tuned.head.weight, pre_model.head.weight)   # the rest did train
    # a fresh run with another seed pretrains its own autoencoder
    fresh = load_checkpoint(train(ds, replace(cfg, seed=3), tmp_path / "fresh", progress=False))[0]
    assert not torch.equal(fresh.dae_encoder[0].weight, pre_model.dae_encoder[0].weight)
