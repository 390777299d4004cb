"""The multi-frame 4D motion CVAE (multi-frame 4D motion paper §3.2, Fig. 2).

One latent vector z per 100-frame cycle::

    encoder  chi (B, N, C) -> flatten -> [Linear, ReLU] x len(hidden) -> Linear -> (mu, log sigma^2)
    z = mu + eps * sigma (training), z = mu (reconstruction)
    decoder  [z, beta] -> [Linear, ReLU] x len(hidden) (hidden reversed) -> Linear -> chi_hat (B, N, C)

The encoder is **not** conditioned on beta, the decoder is (the paper's choice: with a continuous
shape and few cycles per body, a latent distribution per beta cannot be learnt; conditioning the
encoder cost the authors accuracy). Outputs are in the dataset's normalised chi (rotations minus
identity, translation / gamma_scale, time / 3 s); ``mocapviz.bodies.torch_mesh`` turns them into
meshes. The paper gives no layer widths; ours are :attr:`CVAE4DConfig.hidden`.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import torch
from torch import nn

from mocapviz.models.protocol import register_model


@dataclass(frozen=True)
class CVAE4DConfig:
    n_frames: int = 100
    n_chi: int = 130          # numbers per frame: 6 x kept joints + 3 (Gamma) + 1 (Phi)
    n_beta: int = 6           # anny's phenotypes (the paper: SMPL's 8 betas)
    latent: int = 64
    # encoder widths; the decoder uses them reversed. 256 at the chi end, well above latent +
    # beta (70), so no layer is narrower than the code it carries (48 was: Fig. 3 went flat);
    # the two chi-wide layers (2 x 256 x 13,000 weights) make a float16 checkpoint 13 MB
    hidden: tuple[int, ...] = (256, 256)

    def __post_init__(self):
        object.__setattr__(self, "hidden", tuple(int(h) for h in self.hidden))

    @property
    def n_in(self) -> int:
        return self.n_frames * self.n_chi

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str) -> CVAE4DConfig:
        return cls(**json.loads(s))


def _mlp(sizes) -> nn.Sequential:
    """Linear layers between ``sizes`` with ReLU after every one but the last."""
    layers = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


@register_model("cvae4d")
class CVAE4D(nn.Module):
    config_class = CVAE4DConfig
    input_names = ("chi", "beta")

    def __init__(self, cfg: CVAE4DConfig):
        super().__init__()
        self.cfg = cfg
        self.encoder = _mlp((cfg.n_in, *cfg.hidden, 2 * cfg.latent))
        self.decoder = _mlp((cfg.latent + cfg.n_beta, *reversed(cfg.hidden), cfg.n_in))

    @classmethod
    def config_for(cls, train_cfg, layout) -> CVAE4DConfig:
        """``layout``: (n_frames, n_chi, n_beta) of the dataset; widths from ``train_cfg``."""
        n_frames, n_chi, n_beta = layout
        return CVAE4DConfig(n_frames, n_chi, n_beta, train_cfg.latent, tuple(train_cfg.hidden))

    @property
    def shared_layer(self) -> torch.Tensor:
        """The weight of the decoder's last hidden layer: the last weights that every part of
        chi depends on (GradNorm's W; the output layer's rows are per part)."""
        return [m for m in self.decoder if isinstance(m, nn.Linear)][-2].weight

    def encode(self, chi: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """chi (B, N, C) -> mu (B, L), log sigma^2 (B, L)."""
        mu, logvar = self.encoder(chi.reshape(chi.shape[0], -1)).chunk(2, dim=-1)
        return mu, logvar

    def decode(self, z: torch.Tensor, beta: torch.Tensor) -> torch.Tensor:
        """z (B, L), beta (B, n_beta) -> chi_hat (B, N, C)."""
        out = self.decoder(torch.cat([z, beta.to(z.dtype)], dim=-1))
        return out.reshape(z.shape[0], self.cfg.n_frames, self.cfg.n_chi)

    def forward(self, chi: torch.Tensor, beta: torch.Tensor, sample: bool | None = None) -> dict:
        """Reconstruction of chi (B, N, C) on bodies beta (B, n_beta): dict with ``chi`` (B, N, C),
        ``mu``, ``logvar`` and ``z`` (B, L). ``sample`` (default: in training mode) draws
        z = mu + eps sigma; otherwise z = mu."""
        mu, logvar = self.encode(chi)
        sample = self.training if sample is None else sample
        z = mu + torch.randn_like(mu) * torch.exp(0.5 * logvar) if sample else mu
        return dict(chi=self.decode(z, beta), mu=mu, logvar=logvar, z=z)

    def stepper(self, batch: int, backend: str):
        raise NotImplementedError("the 4D CVAE decodes whole cycles; it has no frame-by-frame stepper")


def kl_divergence(mu: torch.Tensor, logvar: torch.Tensor) -> torch.Tensor:
    """KL(N(mu, sigma^2) || N(0, 1)) summed over the latent dimensions, averaged over the batch:
    0.5 sum(mu^2 + sigma^2 - log sigma^2 - 1).

    The paper calls its term the "squared KL divergence"; we read it as this closed form (whose
    terms are squares of mu and sigma), not the square of the divergence, which would vanish
    with its gradient near the prior and grow quartically away from it."""
    return 0.5 * (mu ** 2 + logvar.exp() - logvar - 1).sum(-1).mean()
