"""CCNet's configuration (sizes of x_n, c_n and the network) and the named presets."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import numpy as np

ROOT_CHANNELS = 4   # the root block (vx, vz, heading rate, height) ends x's continuous part (features.ccnet)


# options taken out of CCNetConfig, and their value when unused: a checkpoint whose config holds
# one with this value still loads (docs/experiments.md has what each did)
REMOVED_OPTIONS = {"height_anchor": [], "latent_ar": 0.0, "learned_prior": False, "residual_gain": 1.0,
                   "residual_ranges": []}


def drop_removed_options(d: dict, removed: dict, what: str) -> dict:
    """``d`` (a config as JSON) without the ``removed`` options (name -> unused value, as JSON
    gives it); an option set to anything else cannot be honoured: ValueError."""
    d = dict(d)
    for name, unused in removed.items():
        if name in d and (value := d.pop(name)) != unused:
            raise ValueError(f"{what} option {name} = {value!r} was removed (docs/experiments.md); "
                             "a model trained with it needs the code of git tag zoo-history-2026-12")
    return d


@dataclass(frozen=True)
class CCNetConfig:
    n_x: int = 306            # frame vector size (continuous + 2 contacts)
    n_contact: int = 2        # foot-contact labels at the end of x
    n_skel: int = 73          # c^s
    n_traj: int = 12          # c^d (+ 2 with a phase)
    n_types: int = 13         # c^t
    channels: int = 48        # residual channels C (the gated unit has 2C)
    skip_channels: int = 64   # skip channels S (the decoder's input)
    dilations: tuple[int, ...] = (2,) * 20  # one dilation per SRB
    kernel_size: int = 2      # the dilated convs' kernel (the paper's 2)
    dropout: float = 0.5      # dropout on the input frames
    sigma_min: float = 1e-4   # sigma = max(exp(-s), sigma_min)
    skip_bias: bool = False   # 20 skip biases add up in Eq. 4; without them the decoder's ReLU stays alive more often
    residual: bool = False    # the mean is x_t + the decoder's output (a named deviation; not the paper's)
    latent: int = 0           # size of a latent z the decoder sees, a conditional VAE (0: the paper's network)
    posterior_hidden: int = 256  # hidden width of z's posterior network
    latent_hold: int = 1      # one z per this many frames (a knot), not one per frame
    latent_lerp: bool = False  # z blended linearly between knots, not held over a block
    traj_without_z: bool = False  # the predicted c^d is decoded from the skip sum without z
    root_without_z: bool = False  # so is the root block (planar velocity, heading rate, height)
    phase: bool = False       # the last two channels of c^d are a local motion phase (sin, cos)
    phase_harmonics: int = 0  # K > 0: a phase-functioned decoder, weights a Fourier series of K harmonics in the phase

    def __post_init__(self):
        if self.kernel_size != 2:
            raise ValueError("CCNet's SRBs use kernel size 2 (paper §3.2.2)")
        if not self.dilations or min(self.dilations) < 1:
            raise ValueError("dilations must be positive")
        object.__setattr__(self, "dilations", tuple(int(d) for d in self.dilations))
        if self.phase and self.n_traj < 2:
            raise ValueError("a phase needs two c^d channels")
        if self.phase_harmonics and not self.phase:
            raise ValueError("phase_harmonics needs phase")
        if self.latent < 0:
            raise ValueError(f"latent must be >= 0, got {self.latent}")
        if self.latent_hold < 1:
            raise ValueError(f"latent_hold must be >= 1, got {self.latent_hold}")

    @property
    def residual_slices(self) -> list[slice]:
        """The continuous channels whose mean is x_t + the decoder's output (none: the paper's)."""
        return [slice(0, self.n_continuous)] if self.residual else []

    def add_residual(self, mean, x):
        """The residual rule, the one home of it: on each residual slice the decoder gave the
        change from x_t, so ``mean[..., sl] += x[..., sl]``, in place (numpy arrays or torch
        tensors, ``x`` the input frames). Returns ``mean``."""
        for sl in self.residual_slices:
            mean[..., sl] += x[..., sl]
        return mean

    @property
    def n_continuous(self) -> int:
        """Channels of x modelled by the Gaussian: all but the contact labels."""
        return self.n_x - self.n_contact

    @property
    def receptive_field(self) -> int:
        return receptive_field(self.dilations, self.kernel_size)

    @property
    def output_slices(self) -> dict[str, slice]:
        """Where each part sits in the decoder's raw output (..., n_out): the Gaussian mean and
        its s (sigma = exp(-s)) of x_{t+1}'s continuous part, the contact logits, and the mean
        and s of the predicted trajectory control c^d_{t+2}. The one home of this layout."""
        n, k, d = self.n_continuous, self.n_contact, self.n_traj
        out, at = {}, 0
        for name, size in (("mean", n), ("s", n), ("contact_logits", k), ("traj_mean", d), ("traj_s", d)):
            out[name] = slice(at, at + size)
            at += size
        return out

    @property
    def without_z_columns(self) -> np.ndarray:
        """Columns of the raw output decoded from the skip sum without z (``traj_without_z``:
        the predicted c^d's mean and s; ``root_without_z``: the root block's mean and s, the
        last ROOT_CHANNELS of x's continuous part), ascending."""
        out = self.output_slices
        cols = []
        if self.root_without_z:
            for part in ("mean", "s"):
                cols += range(out[part].stop - ROOT_CHANNELS, out[part].stop)
        if self.traj_without_z:
            cols += range(out["traj_mean"].start, self.n_out)
        return np.asarray(cols, dtype=np.int64)

    @property
    def n_out(self) -> int:
        return 2 * self.n_continuous + self.n_contact + 2 * self.n_traj

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str) -> "CCNetConfig":
        """A saved config; a removed option (:data:`REMOVED_OPTIONS`) at its unused value is dropped."""
        d = drop_removed_options(json.loads(s), REMOVED_OPTIONS, "CCNetConfig")
        d["dilations"] = tuple(d["dilations"])
        return cls(**d)


def receptive_field(dilations, kernel_size: int = 2) -> int:
    """Eq. 3: CRL = (k - 1) + sum_i d_i (k - 1) frames."""
    return (kernel_size - 1) + sum(int(d) * (kernel_size - 1) for d in dilations)


# Named sizes. "paper": 20 SRBs with d = 2 (CRL 41); the paper's Fig. 2 channel counts are not
# legible in our copy, so 256 residual/skip channels (a WaveNet-typical width) is our reading.
SIZES = {
    "quick": dict(channels=32, skip_channels=32),
    "default": dict(channels=48, skip_channels=64),
    "wide": dict(channels=96, skip_channels=128),
    "paper": dict(channels=256, skip_channels=256),
}


def make_config(size: str = "default", **overrides) -> CCNetConfig:
    if size not in SIZES:
        raise KeyError(f"unknown CCNet size {size!r}; choose from {sorted(SIZES)}")
    return CCNetConfig(**{**SIZES[size], **overrides})
