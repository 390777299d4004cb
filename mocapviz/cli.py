"""The ``mocapviz`` command (also ``python -m mocapviz``).

``mocapviz generate --seed walk.bvh --seconds 20 --out walk_more.bvh`` continues a user's own
motion file with a trained model (:mod:`mocapviz.tasks.generate_bvh`); ``mocapviz map walk.bvh``
prints how that file's joints take the model's (:mod:`mocapviz.skeleton_map`). Mistakes in the
request (a missing file, an unknown motion type, a seed too short, a skeleton that does not
map) end with one line on stderr and exit status 2, not a traceback.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from mocapviz.errors import MocapFormatError

from mocapviz.skeleton import SkeletonMapError
from mocapviz.tasks.generation_defaults import (GENERATION_MODEL, PACE, PACES, SAMPLING_TEMPERATURE, Z_SEARCH, Z_SOURCE,
                                                Z_SOURCES)

USER_ERRORS = (FileNotFoundError, MocapFormatError, SkeletonMapError)  # and GenerateError (imported with torch)


def _generate_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("generate", help="continue a BVH (or ASF/AMC) seed with a trained model, write BVH",
                       description="Continue your own motion file with CCNet: the output BVH holds the seed "
                                   "frames, then the generated ones, at 60 fps on the seed's own skeleton.")
    p.add_argument("--model", default=GENERATION_MODEL,
                   help="a .safetensors checkpoint, or a model name looked up in $MOCAPVIZ_ZOO (mocapviz.zoo) and in "
                        "models/zoo/ of the current folder and its parents (default: %(default)s)")
    p.add_argument("--seed", required=True, help="the seed motion: a .bvh file, or an .amc file with --asf")
    p.add_argument("--asf", help="the ASF skeleton of an .amc seed")
    p.add_argument("--fps", type=float, default=120.0, help="frame rate of an .amc seed (default: %(default)s)")
    p.add_argument("--up", choices=("y", "z", "auto"), default="y", help="the seed's up axis (default: %(default)s)")
    p.add_argument("--joint-map", help="JSON object: seed joint name -> CCNet joint name (null to skip a joint), "
                                       "over the automatic map (see `mocapviz map FILE`)")
    p.add_argument("--seed-seconds", type=float, default=2.0,
                   help="seconds of the seed fed to the model; any length from one frame, with a warning under "
                        "the model's receptive field (default: %(default)s)")
    p.add_argument("--seconds", type=float, default=10.0, help="seconds to generate (default: %(default)s)")
    p.add_argument("--type", action="append", dest="types", metavar="NAME",
                   help="motion type (repeat it with --switch-every; default: walk)")
    p.add_argument("--switch-every", type=float, metavar="S", help="seconds before the next --type")
    p.add_argument("--path", help="JSON list of [x, z] ground points in metres, relative to where the seed "
                                  "ends (world axes), resampled to one per generated frame")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--sample", dest="sample", action="store_true",
                      help="sample: draw the model's latent z from its prior (a latent model, such as the default), "
                           "or each frame from the predicted Gaussian")
    mode.add_argument("--mean", dest="sample", action="store_false", help="take its mean (default)")
    p.add_argument("--temperature", type=float, default=SAMPLING_TEMPERATURE, metavar="T",
                   help="with --sample, scale the spread of the draws by T: 1 is the model's own (default: %(default)s)")
    p.add_argument("--pace", choices=PACES, default=PACE,
                   help="without --path: hold the seed's own pace (its last second's; seed), or follow the "
                        "speed it plans frame by frame (network; runs tend to slow down; default: %(default)s)")
    p.add_argument("--z-source", choices=Z_SOURCES, default=Z_SOURCE,
                   help="a latent model's z after the seed: read from the seed's own frames, so the body keeps "
                        "how it holds itself (seed), or the motion type's usual z (type; default: %(default)s)")
    p.add_argument("--z-search", type=int, default=Z_SEARCH, metavar="K",
                   help="with --z-source seed: try K codes around the seed's z, then K around the best, 8 s each, and "
                        "keep the one that holds the seed's root height, lean, pace and activity best (0: the seed's z "
                        "as read; default: %(default)s)")
    p.add_argument("--noise-correlation", type=float, default=0.0, metavar="RHO",
                   help="with --sample, the draws' correlation from one frame to the next (0: independent, the "
                        "paper's; every frame stays a draw of its predicted PDF; default: %(default)s)")
    p.add_argument("--ik", action=argparse.BooleanOptionalAction, default=True,
                   help="foot-contact leg IK against sliding (default: on)")
    p.add_argument("--skeleton-z", type=float, default=3.0, metavar="Z",
                   help="the seed's root height (by scaling it) and c^s are kept within Z standard deviations of "
                        "the training skeletons' mean: the network only knows their sizes and proportions (0: their "
                        "mean skeleton; inf: yours as is; default: %(default)s)")
    p.add_argument("--random-seed", type=int, default=0, help="seed of the sampling noise (default: %(default)s)")
    p.add_argument("--out", required=True, help="the BVH file to write")
    p.set_defaults(run=generate)
    return p


def generate(args) -> None:
    # imported here so that --help and argument errors do not wait for torch
    from tqdm.auto import tqdm

    from mocapviz.io.bvh import write_bvh
    from mocapviz.tasks.generate_bvh import ShortSeedWarning, generate_from_seed, load_seed, read_json
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.zoo import find_checkpoint

    model, norm, meta = load_checkpoint(find_checkpoint(args.model))
    seed = load_seed(args.seed, args.asf, args.fps, args.up)
    joint_map, path = read_json(args.joint_map, "joint map"), read_json(args.path, "path file")
    with warnings.catch_warnings():
        warnings.simplefilter("always", ShortSeedWarning)
        shown = warnings.showwarning

        def show(message, category, *rest, **kw):  # a short seed: one line, before the progress bar
            if issubclass(category, ShortSeedWarning):
                print(f"mocapviz generate: warning: {message}", file=sys.stderr, flush=True)
            else:
                shown(message, category, *rest, **kw)
        warnings.showwarning = show
        result = generate_from_seed(seed, model, norm, meta, types=args.types or ["walk"], seconds=args.seconds,
                                    switch_every=args.switch_every, path_xz=path, sample=args.sample, ik=args.ik,
                                    seed_seconds=args.seed_seconds, joint_map=joint_map, rng_seed=args.random_seed,
                                    skeleton_z=args.skeleton_z, temperature=args.temperature,
                                    noise_correlation=args.noise_correlation, pace=args.pace,
                                    z_source=args.z_source, z_search=args.z_search, progress=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_bvh(result.motion, out)
    m = result.motion
    if result.z_search is not None:
        tqdm.write(result.z_search.summary())
    tqdm.write(f"wrote {out}: {m.n_frames} frames at {m.fps:g} fps ({result.n_seed} seed + "
               f"{m.n_frames - result.n_seed} generated), {m.skeleton.n_joints} joints"
               + ("; skipped a leading T-pose frame of the seed" if seed.meta.get("tpose_frames") else ""))


def _map_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("map", help="print how a file's joints map onto CCNet's 25 (what generate would use)",
                       description="Print the mapping generate would use: file joint -> CCNet joint, the CCNet "
                                   "joints made up, the file joints composed into a CCNet joint and those skipped.")
    p.add_argument("file", help="a .bvh file, an .asf file, or an .amc file with --asf")
    p.add_argument("--asf", help="the ASF skeleton of an .amc file")
    p.add_argument("--up", choices=("y", "z", "auto"), default="y", help="the file's up axis (default: %(default)s)")
    p.add_argument("--joint-map", help="JSON object: file joint name -> CCNet joint name (null to skip a joint), "
                                       "over the automatic map")
    p.set_defaults(run=show_map)
    return p


def show_map(args) -> None:
    from mocapviz.io.asfamc import read_asf
    from mocapviz.skeleton_map import map_skeleton
    from mocapviz.tasks.generate_bvh import load_seed, read_json

    path = Path(args.file)
    if path.suffix.lower() == ".asf" and path.is_file():
        skeleton = read_asf(path).to_skeleton()
    else:
        skeleton = load_seed(path, args.asf, up=args.up).skeleton
    print(map_skeleton(skeleton, read_json(args.joint_map, "joint map"), source=str(path)).table())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="mocapviz", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    _generate_parser(sub)
    _map_parser(sub)
    args = parser.parse_args(argv)
    from mocapviz.tasks.generate_bvh import GenerateError
    try:
        args.run(args)
    except (*USER_ERRORS, GenerateError) as e:
        print(f"mocapviz {args.command}: error: {e}", file=sys.stderr)
        return 2
    return 0
