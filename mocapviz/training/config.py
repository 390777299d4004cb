"""Training configuration: optimiser schedule, batch, window, noise, loss weights, model size,
evaluation and checkpoint cadence; and the named configs (:data:`TRAIN_CONFIGS`). The runs of
configs that did not help, and why the CPU configs use Adam, are in docs/experiments.md."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import torch

from mocapviz.features.ccnet import FeatureLayout
from mocapviz.models.ccnet_config import drop_removed_options
from mocapviz.models.protocol import model_class
from mocapviz.training.losses import LAMBDAS

OPTIMIZERS = {"rmsprop": torch.optim.RMSprop, "adam": torch.optim.Adam}

# options taken out of TrainConfig, and their value when unused: a saved config holding one with
# this value still reads (docs/experiments.md has what each did)
REMOVED_OPTIONS = {"height_anchor": False, "latent_ar": 0.0, "learned_prior": False, "nll_beta": 0.0,
                   "offset_noise_std": 0.0, "residual_blocks": [], "residual_gain": 1.0, "rollout_from": 0,
                   "skel_per_body": False, "type_balance": 0.0}


@dataclass(frozen=True)
class TrainConfig:
    model: str = "ccnet"            # registered model name (mocapviz.models.protocol)
    size: str = "default"           # model size name (mocapviz.models.ccnet_config.SIZES)
    steps: int = 4000               # optimiser steps
    batch_size: int = 32            # windows per step (split across ranks under DDP)
    window: int = 60                # frames per window, NCF
    eval_window: int = 0            # frames per validation and test window (0: ``window``)
    lr: float = 1e-4                # learning rate at step 0
    lr_final: float = 1e-6          # learning rate at the last step (exponential decay in between)
    noise_std: float = 0.03         # std of the i.i.d. noise added to the normalised inputs
    lambdas: tuple[float, float, float] = LAMBDAS  # loss weights of smoothness, contacts, c^d (Eq. 6)
    dilations: tuple[int, ...] = (2,) * 20  # one dilation per SRB
    dropout: float = 0.5            # dropout on the input frames
    hidden_inputs: tuple[str, ...] = ()  # inputs the model never sees (WindowData.HIDEABLE), for ablations
    residual: bool = False          # the network predicts x_{t+1} - x_t (CCNetConfig.residual)
    feedback_passes: int = 0        # inputs of the window's second half: the model's own means, k passes
    latent: int = 0                 # size of CCNet's latent z (CCNetConfig.latent; 0: the paper's)
    kl_weight: float = 1.0          # weight of the latent's KL term (1: the ELBO)
    latent_hold: int = 1            # one z per this many frames (CCNetConfig.latent_hold)
    latent_lerp: bool = False       # z blended between knots, not held (CCNetConfig.latent_lerp)
    traj_without_z: bool = False    # the predicted c^d does not see z (CCNetConfig.traj_without_z)
    root_without_z: bool = False    # nor does the root (CCNetConfig.root_without_z)
    body_scale: tuple[float, ...] = ()  # (lo, hi): each window's body scaled by s ~ U(lo, hi) (WindowData.scaled)
    phase: bool = False             # c^d gains a local motion phase (CCNetConfig.phase, features.phase)
    phase_harmonics: int = 0        # a phase-functioned decoder (CCNetConfig.phase_harmonics)
    optimizer: str = "rmsprop"      # "rmsprop" (the paper's) or "adam" (OPTIMIZERS)
    seed: int = 0                   # seeds every draw of the run, with the rank and the step
    eval_every: int = 250           # steps between validation and test evaluations
    checkpoint_every: int = 250     # steps between checkpoints
    threads: int = 1                # torch threads: 1 is fastest on a shared 2-core machine
    device: str = "cpu"             # "cuda" trains on a GPU (TF32 matmuls; the data stays on the GPU)
    minutes: float = 0.0            # > 0: a time budget; ``steps`` is then set from the measured step time

    def __post_init__(self):
        if self.optimizer not in OPTIMIZERS:
            raise ValueError(f"unknown optimizer {self.optimizer!r}; choose from {sorted(OPTIMIZERS)}")
        if self.body_scale and not (len(self.body_scale) == 2 and 0 < self.body_scale[0] <= self.body_scale[1]):
            raise ValueError(f"body_scale is (lo, hi) with 0 < lo <= hi, or (), got {self.body_scale}")

    def make_optimizer(self, params) -> torch.optim.Optimizer:
        return OPTIMIZERS[self.optimizer](params, lr=self.lr)

    def model_config(self, layout: FeatureLayout):
        """The model's config for a feature layout (the registered class decides how)."""
        return model_class(self.model).config_for(self, layout)

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str | dict) -> "TrainConfig":
        """A saved config (runs before "model" existed were CCNet); a removed option
        (:data:`REMOVED_OPTIONS`) at its unused value is dropped, any other value refused."""
        d = drop_removed_options(json.loads(s) if isinstance(s, str) else dict(s), REMOVED_OPTIONS, "TrainConfig")
        d["lambdas"], d["dilations"] = tuple(d["lambdas"]), tuple(d["dilations"])
        d["body_scale"] = tuple(d.get("body_scale", ()))
        d["hidden_inputs"] = tuple(d.get("hidden_inputs", ()))
        return cls(**d)


# The named configs. quick, default and the CPU runs use Adam at 1e-3 (RMSprop at 1e-3 saturated the
# gates early; at the paper's 1e-4 a CPU budget gets too few steps: docs/experiments.md)
TRAIN_CONFIGS = {
    # a few minutes on 2 CPU cores
    "quick": TrainConfig(size="quick", steps=1200, batch_size=16, lr=1e-3, lr_final=1e-5, optimizer="adam",
                         eval_every=200, checkpoint_every=200),
    # the paper's network at a CPU size (ccnet_default)
    "default": TrainConfig(size="default", steps=3000, batch_size=32, lr=1e-3, lr_final=1e-5, optimizer="adam"),
    # the recommended generator (ccnet_generate): "default" plus a local phase in c^d, a phase-functioned
    # decoder, a latent z per knot 10 frames apart blended in between, c^d and the root decoded without z,
    # and every body at 0.9-1.25x its size
    "generate": TrainConfig(size="default", steps=3000, batch_size=32, lr=1e-3, lr_final=1e-5, optimizer="adam",
                            phase=True, phase_harmonics=2, latent=32, latent_hold=10, latent_lerp=True,
                            traj_without_z=True, root_without_z=True, body_scale=(0.9, 1.25)),
    # the paper's sizes and schedule (RMSprop, lr 1e-4 decaying to 1e-6, batch 256)
    "paper": TrainConfig(size="paper", steps=200_000, batch_size=256, eval_every=2000,
                         checkpoint_every=2000),
    # the paper's network as committed (ccnet_paper): an 80-minute CPU budget, width 96 / skip 128, a residual mean
    "paper_next_frame": TrainConfig(size="wide", steps=10 ** 6, batch_size=32, lr=1e-3, lr_final=1e-5,
                                    optimizer="adam", minutes=80.0, residual=True, eval_every=1),
    # the paper's network, loss and batch on one GPU for a time budget (tools/gpu_train.sh); Adam
    "paper_gpu": TrainConfig(size="paper", steps=10 ** 6, batch_size=256, lr=1e-3, lr_final=1e-5,
                             optimizer="adam", device="cuda", minutes=6.0, eval_every=1),
    # ... with a residual mean (CCNetConfig.residual)
    "paper_gpu_residual": TrainConfig(size="paper", steps=10 ** 6, batch_size=256, lr=1e-3, lr_final=1e-5,
                                      optimizer="adam", device="cuda", minutes=6.0, residual=True,
                                      eval_every=1),
}
