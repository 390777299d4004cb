"""4D motion CVAE speed: decoding to meshes, and a phase-2 training step against meshing alone.

    .venv/bin/python benchmarks/bench_cvae.py [--repeat 5] [--threads 1]

- decode_ms_per_cycle: z -> chi_hat -> every anny vertex (100 frames), batch 1 and batch 16
  (ms per cycle), no gradients;
- phase-2 step: batch 16 x 100 frames, the whole training step of
  :mod:`mocapviz.training.cvae4d` (encode, decode, mesh chi_hat and, without gradients, chi;
  spatial + time losses, GradNorm's per-task backward passes, KL, Adam), and the mesh path
  alone (mesh chi_hat, squared L2, backward to chi_hat), each against forward-only meshing of
  the same batch (chi_hat -> vertices, no gradients): ``step_over_mesh`` and
  ``fwd_bwd_over_fwd`` (target <= 3), on every vertex and on the 1024-vertex subset that the
  committed phase-2 run uses.

Real cycles from the body4d dataset (quick config, built and cached if needed), tiled to 16.
Medians of ``--repeat`` runs, alternating the two timed functions. Last line: one JSON object.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch
from bench_body import (
    _interleaved_ms,  # median ms of functions run alternately (this folder)
)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--threads", type=int, default=1)
    a = p.parse_args(argv)
    torch.set_num_threads(a.threads)

    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    from mocapviz.bodies.anny_model import body_model
    from mocapviz.models.cvae4d import kl_divergence
    from mocapviz.models.protocol import model_class
    from mocapviz.training.cvae4d import CVAE_CONFIGS, TASKS, make_mesher, task_losses
    from mocapviz.training.gradnorm import GradNorm

    ds = build_dataset(Body4DConfig.quick(), progress=False)
    idx = np.resize(np.arange(len(ds)), 16)
    chi, beta = torch.as_tensor(ds.chi[idx]), torch.as_tensor(ds.beta[idx])
    cfg = CVAE_CONFIGS["phase2"]
    cls = model_class("cvae4d")
    torch.manual_seed(0)
    model = cls(cls.config_for(cfg, (chi.shape[1], chi.shape[2], beta.shape[1])))
    body = body_model()
    result = dict(threads=a.threads, batch=16, frames=int(chi.shape[1]), hidden=list(cfg.hidden), latent=cfg.latent)

    full = make_mesher(body, ds.gamma_scale)
    z = torch.randn(16, cfg.latent)
    with torch.no_grad():
        one, batch = _interleaved_ms([lambda: full(model.decode(z[:1], beta[:1]), beta[:1]),
                                      lambda: full(model.decode(z, beta), beta)], a.repeat)
    result.update(decode_ms_per_cycle_b1=round(one, 1), decode_ms_per_cycle_b16=round(batch / 16, 1),
                  vertices=body.n_vertices)

    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    for label, n_subset in (("all", 0), ("subset", cfg.vertex_subset)):
        mesher = make_mesher(body, ds.gamma_scale, n_subset)
        gradnorm = GradNorm(TASKS[2])
        with torch.no_grad():
            chi_hat = model(chi, beta)["chi"]

        def step():
            out = model(chi, beta)
            losses = task_losses(2, out["chi"], chi, beta, mesher)
            opt.zero_grad(set_to_none=True)
            gradnorm.step(losses, out["chi"], model.shared_layer,
                          extra=cfg.kl_weight * kl_divergence(out["mu"], out["logvar"]))
            opt.step()

        def mesh_only():
            with torch.no_grad():
                mesher(chi_hat, beta, vertex_major=True)

        with torch.no_grad():
            truth = mesher(chi, beta, vertex_major=True)
        leaf = chi_hat.clone().requires_grad_(True)

        def mesh_fwd_bwd():  # the path alone: mesh chi_hat, squared L2 to the truth, gradient to chi_hat
            leaf.grad = None
            torch.nn.functional.mse_loss(mesher(leaf, beta, vertex_major=True), truth).backward()

        step_ms, path_ms, mesh_ms = _interleaved_ms([step, mesh_fwd_bwd, mesh_only], a.repeat)
        result[f"{label}_vertices"] = mesher.n_vertices
        result[f"{label}_step_ms"] = round(step_ms, 1)
        result[f"{label}_mesh_fwd_bwd_ms"] = round(path_ms, 1)
        result[f"{label}_mesh_ms"] = round(mesh_ms, 1)
        result[f"{label}_step_over_mesh"] = round(step_ms / mesh_ms, 2)
        result[f"{label}_fwd_bwd_over_fwd"] = round(path_ms / mesh_ms, 2)
        print(f"{mesher.n_vertices} vertices: whole phase-2 step {step_ms:.0f} ms (also meshes the truth), "
              f"mesh fwd + bwd {path_ms:.0f} ms, forward-only meshing {mesh_ms:.0f} ms: "
              f"{step_ms / mesh_ms:.2f}x and {path_ms / mesh_ms:.2f}x (target <= 3)")
    print(f"decode to {body.n_vertices} vertices x 100 frames: {one:.1f} ms per cycle alone, "
          f"{batch / 16:.1f} ms per cycle in a batch of 16")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
