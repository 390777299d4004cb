"""What the ``generate`` command makes of motion files: the pose-level quality of its output.

    .venv/bin/python benchmarks/bench_generate_files.py [--model ccnet_paper] [--seconds 60] [--sample]
        [--temperature 0.5] [--pace seed|network] [FILE.bvh:TYPE ...]

Each file is continued exactly as ``mocapviz generate --seed FILE --type TYPE --seconds S --no-ik``
does, with its defaults (:func:`mocapviz.tasks.generate_bvh.generate_from_seed`); the frames it would write are
mapped back onto the model's 25 joints and the second half of the generated ones is measured
against the dataset's real clips of TYPE (:func:`mocapviz.tasks.generation_quality.motion_quality`:
freezing share, activity, jitter, pose distance, root speed). Without files: walk and run takes
of Bandai and CMU from ``../shared/data`` (a user's own BVH files, not the dataset's clips:
the dataset is resampled and re-based from them). The last line is a JSON object.
"""

from __future__ import annotations

import argparse
import json
import time

import torch

from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from data_prep.sources import find_data_dir
from mocapviz.tasks.generate_bvh import generate_from_seed, load_seed
from mocapviz.tasks.generation_defaults import GENERATION_MODEL, PACE, PACES, SAMPLING_TEMPERATURE
from mocapviz.tasks.generation_quality import QUALITY_KEYS, References, motion_quality, moves_like_real
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.zoo import find_checkpoint

# walk and run seeds the issue names, from two sources and two skeletons (Bandai's and CMU's);
# CMU 16_27 is a walk with a 90-degree turn (../shared/data/cmu/README.md; until 2026-12-03 this
# list had it as a jog, and measured a walk's pace against the joggers': 0.47x) and 127_03 a run
DEFAULT_FILES = ("bandai/dataset-1/dataset-1_walk_active_001.bvh:walk",
                 "bandai/dataset-1/dataset-1_run_active_001.bvh:jog",
                 "cmu/35/35_01.bvh:walk", "cmu/16/16_27.bvh:walk", "cmu/127/127_03.bvh:jog")


def file_quality(path, motion_type: str, model, norm, meta, refs: References, seconds: float, sample: bool,
                 temperature: float, pace: str, rng_seed: int = 0) -> dict:
    result = generate_from_seed(load_seed(path), model, norm, meta, types=[motion_type], seconds=seconds,
                                sample=sample, ik=False, temperature=temperature, pace=pace, rng_seed=rng_seed)
    on_model = result.rig.to_model(result.motion)  # what the BVH holds, on the model's joints
    n_gen = on_model.n_frames - result.n_seed
    return motion_quality(on_model[result.n_seed + n_gen // 2:], motion_type, refs,
                          float(on_model.root_positions[:result.n_seed, 1].mean()))


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("files", nargs="*", help="FILE.bvh:TYPE (default: Bandai and CMU walks and runs)")
    p.add_argument("--model", default=GENERATION_MODEL)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--sample", action="store_true")
    p.add_argument("--temperature", type=float, default=SAMPLING_TEMPERATURE)
    p.add_argument("--pace", choices=PACES, default=PACE)
    a = p.parse_args(argv)
    torch.set_num_threads(1)
    model, norm, meta = load_checkpoint(find_checkpoint(a.model))
    ds = build_dataset(DatasetConfig(), progress=False).with_vocabulary(model.cfg.n_types)
    refs = References(ds)
    files = a.files or [str(find_data_dir() / f) for f in DEFAULT_FILES]
    per_file = {}
    for spec in files:
        path, motion_type = spec.rsplit(":", 1)
        t = time.perf_counter()
        q = file_quality(path, motion_type, model, norm, meta, refs, a.seconds, a.sample, a.temperature, a.pace)
        q["moves_like_real"] = moves_like_real(q)
        per_file[path] = q
        print(f"{path.split('/')[-1]:34s} {motion_type:6s} " + "  ".join(f"{k} {q[k]:.3f}" for k in QUALITY_KEYS)
              + f"  {'pass' if q['moves_like_real'] else 'FAIL'} ({time.perf_counter() - t:.0f} s)")
    res = dict(model=a.model, seconds=a.seconds, sample=a.sample, temperature=a.temperature, pace=a.pace,
               passed=sum(q["moves_like_real"] for q in per_file.values()), files=per_file)
    print(json.dumps(res))
    return res


if __name__ == "__main__":
    main()
