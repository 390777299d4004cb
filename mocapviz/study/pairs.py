"""Question pairs from a CCNet dataset and trained models: real against generated, model against model.

For each chosen clip, the first ``n_seed`` frames seed each model (free-running generation: the
network's own trajectory control, the clip's motion type) and the question shows the next
``seconds`` of the real clip against the same stretch generated from that seed: same body,
same type, same starting pose and place. With two or more models, each later model is also
put against the first, which gives every clip an (A, B, C) triad for the intransitivity rule.
"""

from __future__ import annotations

from mocapviz.study.kit import Clip, Pair
from mocapviz.tasks.generate import Generator
from mocapviz.tasks.generation_quality import seed_batch

MOCAP = "mocap"


def usable_rows(ds, split: str, seconds: float, n_seed: int = 60, n_types: int | None = None) -> list[int]:
    """Clip rows of ``split`` long enough for a seed plus ``seconds`` (of a type below ``n_types``)."""
    c = ds.clips
    long_enough = (c.stop - c.start) >= n_seed + round(seconds * ds.config.fps)
    known = c.type_index < (n_types if n_types is not None else len(ds.motion_types))
    return [int(i) for i in c.index[(c.split == split) & long_enough & known]]


def study_pairs(ds, models: dict, rows, seconds: float, n_seed: int = 60) -> list[Pair]:
    """Pairs for :func:`mocapviz.study.kit.build_kit`.

    ``models``: name -> (model, normaliser), the first one the reference (e.g. CCNet);
    ``rows``: clip rows of ``ds`` (see :func:`usable_rows`). Groups: "mocap vs <name>" (the
    generated clip counted) for every model, and "<name> vs <first>" (the first model's clip
    counted) for every later model. Motions: 60 fps, metres, Y up, no IK clean-up (what the
    network made).
    """
    rows = list(rows)
    n = round(seconds * ds.config.fps)
    real = {}
    for i in rows:
        clip = ds.clips.iloc[i]["clip"]
        real[i] = Clip(f"{MOCAP}:{clip}", MOCAP, ds.clip_motion(i)[n_seed:n_seed + n])
    generated = {}
    for name, (model, norm) in models.items():
        x, traj, skel, types = seed_batch(ds, rows, n_seed, model.cfg.n_types)
        out = Generator(model, norm, batch=len(rows)).run(x, skel, types, n, seed_traj=traj)
        for k, i in enumerate(rows):
            r = ds.clips.iloc[i]
            motion = out.motion(k, ds.skeleton(i), (r.root_x, r.root_y, r.root_z), r.heading, ik=False)
            generated[name, i] = Clip(f"{name}:{r['clip']}", name, motion[n_seed:n_seed + n])
    first, *others = list(models)
    pairs = [Pair(f"{MOCAP} vs {name}", real[i], generated[name, i]) for i in rows for name in models]
    pairs += [Pair(f"{name} vs {first}", generated[name, i], generated[first, i]) for i in rows for name in others]
    return pairs
