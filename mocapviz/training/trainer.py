"""Train CCNet (paper §4.2): RMSprop (or Adam: ``TrainConfig.optimizer``), lr decaying exponentially, input noise, whole windows.

Every step draws ``batch_size`` windows of ``window`` frames at random (clip, then start), adds
i.i.d. N(0, 0.03^2) noise to the normalised inputs, and trains on every frame of the window at
once (the network is causal, so output t sees inputs <= t only). The learning rate decays
exponentially from ``lr`` to ``lr_final`` over ``steps``.

Reproducible and resumable: the random draws of step k (windows, noise, dropout) come from
generators seeded with (seed, rank, k), so a run resumed from a checkpoint continues exactly the
loss curve of an uninterrupted run. Checkpoints (safetensors, written atomically) hold model,
optimizer, normaliser and configs; a CSV logs the losses.

Model selection uses the validation split only: every ``eval_every`` steps the validation and
test losses are computed (the test columns are for reporting), and the model with the lowest
validation NLL so far is kept as ``best.safetensors`` (model only; its metadata records the step
and its validation and test NLL). On resume the best-so-far value comes back from the CSV (the run folder: :mod:`.runs`).
Under ``torchrun`` (WORLD_SIZE > 1) the model is wrapped in DistributedDataParallel (gloo), each rank draws its own windows, and only
rank 0 writes files.

The loop knows models only through :mod:`mocapviz.models.protocol`: the registered class of
``TrainConfig.model`` builds the model, its ``input_names`` pick the batch keys it takes, and its
loss is ``LOSSES[model.name]``. The command line is ``python -m data_prep train``.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from tqdm.auto import tqdm

from mocapviz.models.protocol import model_class
from mocapviz.training.checkpoint import load_checkpoint, save_checkpoint
from mocapviz.training.config import TrainConfig
from mocapviz.training.distributed import rank_and_world
from mocapviz.training.losses import LAMBDAS, LOSSES
from mocapviz.training.runs import BEST, CHECKPOINT, LOG, best_row, read_log, write_log
from mocapviz.training.windows import WindowData


def model_inputs(model, b: dict) -> dict:
    """The batch keys the model's forward takes in training: its ``input_names``, and the true
    next frames for a CCNet with a latent (its posterior sees them)."""
    names = model.input_names + (("target_x",) if model.cfg.latent else ())
    return {k: b[k] for k in names}


@torch.no_grad()
def fed_back(net, b: dict, inputs: dict, passes: int) -> torch.Tensor:
    """Inputs ``b["x"]`` (B, T, n_x) whose second half is the model's own predicted means, as in
    generation (``TrainConfig.feedback_passes``).

    The first half stays the (noisy) data, like a seed. Each pass feeds the means predicted by the
    previous one: after k passes an input of the second half carries the errors of up to k chained
    predictions, so the network trains on its own errors (i.i.d. input noise does not look like
    them). The constant channels (``b["varying"]`` false) and the contact labels stay the data's.
    ``inputs``: the model's inputs (:func:`model_inputs`), whose ``x`` is replaced.
    """
    x, varying = b["x"], b["varying"]
    t0, n = x.shape[1] // 2, varying.shape[0]
    for _ in range(passes):
        mean = net(**dict(inputs, x=x))["mean"]
        new = x.clone()
        new[:, t0:, :n][..., varying] = mean[:, t0 - 1:-1][..., varying]  # the mean at t-1 predicts frame t
        x = new
    return x


@torch.no_grad()
def rolled_out(model, b: dict, start: int, guided: bool = True) -> torch.Tensor:
    """Inputs ``b["x"]`` (B, T, n_x) whose frames from ``start`` on are the model's own
    free-running means, as in generation (what :func:`mocapviz.tasks.one_step.drift_table` measures).

    Frames before ``start`` stay the (noisy) data, a seed; from there the incremental stepper
    (:mod:`mocapviz.models.steppers`) feeds every predicted mean back as the next input, with the
    window's own trajectory controls. Unlike :func:`fed_back`, whose chains are ``passes``
    predictions deep, a rolled-out frame carries the errors of every prediction since ``start``.
    The constant channels and the contact labels stay the data's.
    """
    x = b["x"].clone()
    varying, cfg = b["varying"], model.cfg
    n, mean_at = varying.shape[0], cfg.output_slices["mean"]
    stepper = model.stepper(x.shape[0], "torch")
    stepper.set_static(b["skel"], b["types"])
    for t in range(x.shape[1] - 1):
        skip = stepper.trunk_step(x[:, t], b["traj"][:, t])
        if t + 1 < start:
            continue
        # a latent model's z: the posterior mean given the true next frame (as in its training),
        # or the prior's mean (as in generation)
        z = None
        if cfg.latent:
            z = model.posterior_of(skip, x[:, t], b["target_x"][:, t])[0] if guided else model.prior_of(skip)[0]
        raw = stepper.head(skip, z, b["traj"][:, t])
        mean = cfg.add_residual(raw[:, mean_at].clone(), x[:, t])
        x[:, t + 1, :n][:, varying] = mean[:, varying]
    return x


def lr_at(cfg: TrainConfig, step: int) -> float:
    return cfg.lr * (cfg.lr_final / cfg.lr) ** (step / max(1, cfg.steps))


@torch.no_grad()
def evaluate(model, data: WindowData, pairs: np.ndarray, lambdas=LAMBDAS, batch: int = 128,
             kl_weight: float = 1.0) -> dict:
    """Mean per-frame losses (no noise, dropout off) over the windows ``pairs``. A latent model's
    NLL is given z at its posterior mean (with the true next frame), plus the KL."""
    was = model.training
    model.eval()
    loss_fn = LOSSES[model.name]
    sums, n = {}, 0
    for i in range(0, len(pairs), batch):
        b = data.batch(pairs[i:i + batch])
        out = model(**model_inputs(model, b))
        parts = loss_fn(out, b, model.cfg, lambdas, kl_weight=kl_weight)
        k = len(pairs[i:i + batch])
        for name, v in parts.items():
            sums[name] = sums.get(name, 0.0) + float(v) * k
        n += k
    model.train(was)
    return {k: v / max(n, 1) for k, v in sums.items()}


def train(ds, cfg: TrainConfig, out_dir, resume: bool = True, progress: bool = True,
          stop_after: int | None = None, init=None) -> Path:
    """Train on ``ds`` into ``out_dir`` (``checkpoint.safetensors``, ``best.safetensors``, ``losses.csv``).

    ``init``: a checkpoint to fine-tune (paper §4.6): its network (its own model config, whatever
    ``cfg``'s size says) and its normaliser (the units the network reads) replace the fresh ones;
    ``cfg`` gives the schedule. A run folder holding a checkpoint resumes from it, not from ``init``.

    With ``resume`` an existing checkpoint in ``out_dir`` is continued exactly. ``stop_after``
    ends the run early at that step (a checkpoint is written), as if interrupted.
    Returns the checkpoint path.
    """
    rank, world = rank_and_world()
    torch.set_num_threads(max(1, cfg.threads // world))
    out_dir = Path(out_dir)
    ckpt, csv_path, best_path = out_dir / CHECKPOINT, out_dir / LOG, out_dir / BEST
    if cfg.body_scale:  # c^s normalised over the scaled bodies training sees (the checkpoint keeps it)
        ds = replace(ds, normaliser=ds.normaliser.body_scaled(*cfg.body_scale))
    pretrained = None
    if init is not None:  # fine-tuning reads the new data in the pretrained network's units
        pretrained = load_checkpoint(init)
        ds = replace(ds, normaliser=pretrained[1])
    device = torch.device(cfg.device)
    if device.type == "cuda":  # TF32, not bf16: x_{t+1} differs from x_t by ~0.01 std, below bf16's step
        torch.backends.cuda.matmul.allow_tf32 = torch.backends.cudnn.allow_tf32 = True
    data = WindowData(ds, cfg.window, phase=cfg.phase, hidden_inputs=cfg.hidden_inputs).to(device)
    # validation and test windows of their own length (TrainConfig.eval_window): an ablation of the
    # training window (NCF) is scored on the same windows as the reference (paper §4.8.1)
    eval_data = data if cfg.eval_window in (0, cfg.window) else \
        WindowData(ds, cfg.eval_window, phase=cfg.phase, hidden_inputs=cfg.hidden_inputs).to(device)
    if len(data.train) == 0:
        raise ValueError(f"the dataset has no training windows of {cfg.window} frames")
    if len(eval_data.val) == 0:
        raise ValueError("the dataset has no validation windows (rebuild it: dataset version >= 2)")
    model_cls = model_class(cfg.model)
    torch.manual_seed(cfg.seed)
    if pretrained is not None:
        if pretrained[0].name != model_cls.name:
            raise ValueError(f"{init} holds a {pretrained[0].name!r} model, the config trains {cfg.model!r}")
        model = pretrained[0].train().to(device)
    else:
        model = model_cls(cfg.model_config(data.layout)).to(device)
    loss_fn = LOSSES[model.name]
    opt = cfg.make_optimizer(model.parameters())
    start = 0
    rows: list[dict] = []
    if cfg.minutes and resume and ckpt.is_file():
        raise ValueError("a run with a time budget (minutes) cannot be resumed: its steps depend on the machine")
    if resume and ckpt.is_file():
        _, _, meta = load_checkpoint(ckpt, optimizer=opt, model=model)
        if TrainConfig.from_json(meta["train_config"]) != cfg:
            raise ValueError(f"{ckpt} was trained with another config; use a new out_dir or resume=False")
        start = int(meta["step"])
        rows = read_log(csv_path, start)
    # a model with a pretraining stage (DAE-LSTM's autoencoder) pretrains in a fresh run; a fine-tune
    # keeps the pretrained stage it starts from
    if start == 0 and pretrained is None and hasattr(model, "pretrain"):
        model.pretrain(data, seed=cfg.seed)
    best = best_row(rows)
    best_val = float(best["val_nll"]) if best else math.inf
    model.train()
    # static_graph: the last block's residual 1x1 conv feeds nothing (only its skip is used)
    net = torch.nn.parallel.DistributedDataParallel(model, static_graph=True) if world > 1 else model
    per_rank = max(1, cfg.batch_size // world)
    meta = dict(train_config=cfg.to_json(), dataset=json.dumps(_dataset_meta(ds)))
    if init is not None:
        meta["init"] = str(init)
    end = cfg.steps if stop_after is None else min(cfg.steps, stop_after)
    t0 = time.perf_counter() - (float(rows[-1]["seconds"]) if rows else 0.0)
    bar = tqdm(range(start, 10 ** 9 if cfg.minutes else end), initial=start, total=cfg.steps,
               desc=f"train {cfg.model}-{cfg.size}", disable=not progress or rank != 0)
    timer = StepBudget(cfg.minutes, start) if cfg.minutes else None
    for step in bar:
        if timer is not None and (steps := timer.steps(step) or timer.overrun(step, cfg.steps)):
            # the budget's steps, measured on this machine: the schedule and cadence follow them
            every = max(cfg.eval_every, steps // 10)  # about ten evaluations, or fewer if asked
            cfg = replace(cfg, steps=steps, eval_every=every, checkpoint_every=every)
            end = cfg.steps if stop_after is None else min(cfg.steps, stop_after)
            meta = dict(meta, train_config=cfg.to_json())
            bar.total = cfg.steps
        if step >= end:
            break
        lr = lr_at(cfg, step)
        for group in opt.param_groups:
            group["lr"] = lr
        rng = np.random.default_rng([cfg.seed, rank, step])
        torch.manual_seed(int(rng.integers(2 ** 62)))
        b = data.batch(data.draw_train(rng, per_rank))
        if cfg.body_scale:  # each window's body at another size (WindowData.scaled)
            b = data.scaled(b, rng.uniform(*cfg.body_scale, size=per_rank))
        b["x"] = b["x"] + cfg.noise_std * torch.randn_like(b["x"])  # input noise (the targets stay clean)
        if cfg.feedback_passes:
            b["x"] = fed_back(net, b, model_inputs(model, b), cfg.feedback_passes)
        out = net(**model_inputs(model, b))
        parts = loss_fn(out, b, model.cfg, cfg.lambdas, kl_weight=cfg.kl_weight)
        opt.zero_grad(set_to_none=True)
        parts["loss"].backward()
        opt.step()
        done = step + 1
        row = dict(step=done, epoch=round(done * cfg.batch_size * cfg.window / data.n_train_frames, 3),
                   lr=lr, **{k: round(float(v.detach()), 5) for k, v in parts.items()}, val_nll="", val_loss="",
                   test_nll="", test_loss="",
                   seconds=round(time.perf_counter() - t0, 2))
        # evaluate on the schedule only (not at a stop_after step), so interrupted runs log and
        # select exactly what an uninterrupted run does
        if (done % cfg.eval_every == 0 and (timer is None or timer.decided)) or done == cfg.steps:
            eval_batch = 512 if device.type == "cuda" else 128
            va = evaluate(model, eval_data, eval_data.val, cfg.lambdas, batch=eval_batch, kl_weight=cfg.kl_weight)
            ev = evaluate(model, eval_data, eval_data.test, cfg.lambdas, batch=eval_batch, kl_weight=cfg.kl_weight)
            row.update(val_nll=round(va["nll"], 5), val_loss=round(va["loss"], 5),
                       test_nll=round(ev["nll"], 5), test_loss=round(ev["loss"], 5))
            # select on the logged (rounded) value, so that a resumed run restores the same best
            if row["val_nll"] < best_val:
                best_val = row["val_nll"]
                if rank == 0:
                    save_checkpoint(best_path, model, ds.normaliser,
                                    dict(meta, step=str(done), val_nll=str(row["val_nll"]),
                                         val_loss=str(row["val_loss"]), test_nll=str(row["test_nll"]),
                                         test_loss=str(row["test_loss"]), selected_by="val_nll"))
        rows.append(row)
        if rank == 0:
            bar.set_postfix(loss=f"{row['loss']:.1f}", val_nll=row["val_nll"], best=f"{best_val:.1f}")
            if (done % cfg.checkpoint_every == 0 and (timer is None or timer.decided)) or done == end:
                save_checkpoint(ckpt, model, ds.normaliser, dict(meta, step=str(done)), optimizer=opt)
                write_log(csv_path, rows)
    if world > 1:
        dist.barrier()
    return ckpt


class StepBudget:
    """Turns a time budget into a step count: times steps ``warmup``..``warmup + measure`` of a
    run and returns (once, at the step after them) how many steps fit ``minutes`` in all,
    leaving 5 % for the evaluations."""

    def __init__(self, minutes: float, start: int, warmup: int = 5, measure: int = 25):
        self.seconds, self.t0 = 60.0 * minutes, time.perf_counter()
        self.at, self.until = start + warmup, start + warmup + measure
        self.t_at = None
        self.decided = False  # the steps are set: the cadence of evaluations is known

    def steps(self, step: int) -> int | None:
        if step == self.at:
            self.t_at = time.perf_counter()
        if step != self.until or self.t_at is None:
            return None
        now = time.perf_counter()
        per_step = (now - self.t_at) / (self.until - self.at)
        self.decided = True
        return step + max(1, int(0.95 * (self.seconds - (now - self.t0)) / per_step))

    def overrun(self, step: int, steps: int) -> int | None:
        """``step + 1`` (this step is the last) once the budget is spent and more steps remain
        (the machine slowed after the measurement, e.g. another run started beside this one)."""
        if step > self.until and step + 1 < steps and time.perf_counter() - self.t0 > self.seconds:
            return step + 1
        return None


def _dataset_meta(ds) -> dict:
    m = ds.meta
    return dict(hash=m.get("hash"), test_subject=m.get("test_subject"), val_clips=m.get("val_clips"),
                joint_names=list(ds.joint_names),
                parents=[int(p) for p in ds.parents], motion_types=m.get("motion_types"),
                fps=ds.config.fps, window=ds.config.window,
                train_mean_joint_speed=m.get("train_mean_joint_speed"))
