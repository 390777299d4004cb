"""Meshing 100-frame cycles: our BodyModel wrapper versus calling anny directly, same run.

    .venv/bin/python benchmarks/bench_body.py [--repeat 7] [--batch 8]

- ms_per_cycle: ``BodyModel.mesh(beta, rotations, root)`` on one real retargeted cycle
  (numpy rotations in, Y-up vertices out), median of ``--repeat`` runs, alternating with
  the direct call so that the load of a shared machine hits both alike;
- anny_ms: ``anny(pose_parameters, phenotype_kwargs)`` with the 4x4 pose tensor and the
  phenotype tensor already built (what our wrapper hands to anny), same model, same cycle;
- overhead_ratio = ms_per_cycle / anny_ms (target <= 1.2);
- cycles_per_s: ``BodyModel.mesh_cycles`` on ``--batch`` real cycles of different bodies.

The cycles come from the body4d dataset (built and cached if needed, quick config). Last
line: one JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import torch


def _median_ms(fn, repeat: int) -> float:
    fn()  # warm-up (warp kernels, allocator)
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(1000 * (time.perf_counter() - t))
    return statistics.median(times)


def _interleaved_ms(fns, repeat: int) -> list[float]:
    """Median ms of each function, run alternately so that load changes hit all alike."""
    for fn in fns:
        fn()
    times = [[] for _ in fns]
    for _ in range(repeat):
        for fn, ts in zip(fns, times):
            t = time.perf_counter()
            fn()
            ts.append(1000 * (time.perf_counter() - t))
    return [statistics.median(ts) for ts in times]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeat", type=int, default=11)
    p.add_argument("--batch", type=int, default=8)
    p.add_argument("--threads", type=int, default=2)
    a = p.parse_args(argv)
    torch.set_num_threads(a.threads)

    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    from mocapviz.bodies.anny_model import body_model
    from mocapviz.bodies.representation import chi_joint_indices, decode

    body = body_model()
    ds = build_dataset(Body4DConfig.quick(), progress=False)
    kept = chi_joint_indices(body.joint_names)
    cycles = []
    for i in range(min(a.batch, len(ds))):
        rot, root, _ = decode(ds.chi[i], kept, body.n_joints, ds.gamma_scale)
        cycles.append((ds.beta[i], rot, root))
    beta, rot, root = cycles[0]

    pose = body.pose_parameters(rot, root)
    pheno = torch.as_tensor(beta, dtype=torch.float32)[None][:, body._anny_order]

    def direct():
        with torch.no_grad():
            return body.anny(pose, phenotype_kwargs=pheno)["vertices"]

    ours, anny_ms = _interleaved_ms([lambda: body.mesh(beta, rot, root), direct], a.repeat)
    v_ours = body.mesh(beta, rot, root).vertices
    assert torch.allclose(v_ours, direct(), atol=1e-6), "wrapper and direct anny disagree"

    import numpy as np
    betas = np.stack([c[0] for c in cycles])
    rots = np.stack([c[1] for c in cycles])
    roots = np.stack([c[2] for c in cycles])
    batch_ms = _median_ms(lambda: body.mesh_cycles(betas, rots, roots), max(3, a.repeat // 2))
    res = dict(ms_per_cycle=round(ours, 2), anny_ms=round(anny_ms, 2), overhead_ratio=round(ours / anny_ms, 3),
               cycles_per_s=round(len(cycles) / (batch_ms / 1000), 2), batch=len(cycles),
               frames_per_cycle=int(rot.shape[0]), vertices=int(v_ours.shape[1]), threads=a.threads,
               skinning=body.anny._skinning_method.__module__.rsplit(".", 1)[-1])
    print(f"wrapper {ours:.1f} ms/cycle, anny direct {anny_ms:.1f} ms, batch of {len(cycles)}: {batch_ms:.0f} ms")
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
