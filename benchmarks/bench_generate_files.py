"""What the ``generate`` command makes of a user's own body: pace, height, posture and activity.

    .venv/bin/python benchmarks/bench_generate_files.py [--model M] [--seconds 60] [--modes mean,sampled]
        [--temperature 0.5] [--pace seed|network] [--z-source seed|type] [--body auto|own|training]
        [--no-ground] [--z-search K] [--diagnose]
        [--keep DIR] [--only NAME,...] [--conventions] [FILE.bvh:TYPE ...]

Seeds far from the training bodies, none of them a training clip, built at run time in a
temporary folder (``--keep DIR`` keeps them) and labelled by what they are:

- real motion retargeted onto skeletons written by hand after exporters' conventions
  (``tests/fixtures/skeletons``: Mixamo T-pose and A-pose with ``mixamorig:`` names and
  fingers, Xsens MVN segment names with the pelvis at the hip joints, the CMU 3ds-Max-style
  hierarchy with straight legs; cm, Y up) with the library's retargeting
  (:func:`mocapviz.bodies.retarget.retarget`: global rotations through the rest alignment,
  hip midpoint followed, two-bone IK on the ankles) after scaling the source to the target's
  leg length. The motion is held out of training: Bandai test-split takes and the held-out
  HDM05 subject ``tr``'s jog;
- the held-out HDM05 subject ``tr``'s own clips (ASF/AMC, its own VICON skeleton).

``--conventions`` measures instead one Bandai test walk retargeted onto each of the 17
exporter conventions the mapping tests write (``tests/fixtures/conventions.py``: Mixamo,
CMU MotionBuilder and 3ds Max, Xsens, Axis Neuron, Rokoko, Rigify, Unreal, Unity, HumanIK,
HDM05, Bandai, DAZ, OptiTrack, a file without side names; one body, so these differ in names,
nesting and rest pose, not in proportions).

Each is continued as ``mocapviz generate --seed FILE --type TYPE --seconds 60`` would
(:func:`mocapviz.tasks.generate_bvh.generate_from_seed` with the command's defaults), mean and
sampled; what the BVH holds is mapped onto the model's joints and seconds 30-60 of the
generated frames are measured against the seed frames the command kept (its first 2 s):

- pace: ground speed of the root, as a ratio to the seed's (bar 0.5-2x);
- height: the root's mean height above the seed's floor (the median over the seed frames of
  the lowest joint), as a ratio to the seed's (bar within 5 %): a body that crouches and one
  that sinks through the floor both fail it; ``feet`` says which (the generated floor, cm
  above the seed's);
- lean: the mean forward lean of the hips -> neck vector from the same vector in the skeleton's
  own rest pose, in the heading frame (:func:`mocapviz.metrics.forward_lean`, degrees), against
  the 5th-95th percentile of the same over the dataset's clips of the seed's motion type.
  ``vert`` (not a bar) is the vector's angle from vertical, the measure the bar used before: it
  adds the rest's own tilt (0 on Bandai's skeleton, -0.7 to -7.9 degrees on the VICON training
  skeletons, -2.3 on the Mixamo one here) and the side-to-side sway, so a Mixamo walk leaning
  2.2 degrees forward from its rest read 1.0 against real walks' 2.0-8.4;
- activity: mean joint speed in the root's heading frame (:func:`mocapviz.metrics.activity`),
  as a ratio to the seed's (bar 0.5-2x).

A ``*`` after the seed's lean: the seed itself leans outside its type's bar (the held-out
subject's jog, +24.6 degrees), so a body that keeps the seed's posture fails the lean bar.
``z`` (not a bar) is the code the posture search chose (:mod:`mocapviz.tasks.posture_search`;
0: the seed's own z; ``--z-search 0`` turns the search off).

``--diagnose`` first prints why a Mixamo body shuffled bent over (its c^s against the training
skeletons', the ``--skeleton-z`` clamp, the rest-pose offset from the training rest, and the
body the network generates on). Files given as ``FILE.bvh:TYPE`` are measured instead of the
built seeds. The last line is a JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import torch

from data_prep.ccnet_dataset import DatasetConfig, build_dataset
from data_prep.sources import find_data_dir
from mocapviz import metrics
from mocapviz.io.bvh import read_bvh, write_bvh
from mocapviz.motion import Motion
from mocapviz.tasks.generate_bvh import BODIES, generate_from_seed, load_seed
from mocapviz.tasks.generation_defaults import (GENERATION_MODEL, PACE, PACES, SAMPLING_TEMPERATURE, Z_SEARCH, Z_SOURCE,
                                                Z_SOURCES)
from mocapviz.tasks.posture_search import posture_of
from mocapviz.tasks.rig import leg_length, retarget_to
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.zoo import find_checkpoint

FIXTURES = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "skeletons"
CONVENTION_SOURCE = "dataset-2_walk_normal_019"  # a test-split Bandai walk, for --conventions
BARS = dict(speed=(0.5, 2.0), height=(0.95, 1.05), activity=(0.5, 2.0))  # lean: per motion type, from the data
LEAN_PERCENTILES = (5, 95)

# hand-written skeleton -> the CMU names the retargeting matches joints by (its other joints,
# fingers, end joints, Xsens' T12, keep their rest pose relative to their parent)
TO_CMU = {
    "mixamo": {"mixamorig:Hips": "Hips", "mixamorig:Spine": "LowerBack", "mixamorig:Spine1": "Spine",
               "mixamorig:Spine2": "Spine1", "mixamorig:Neck": "Neck", "mixamorig:Head": "Head",
               **{f"mixamorig:{s}{j}": f"{s}{j}" for s in ("Left", "Right")
                  for j in ("UpLeg", "Leg", "Foot", "ToeBase", "Shoulder", "Arm", "ForeArm", "Hand")}},
    "xsens": {"Pelvis": "Hips", "L5": "LowerBack", "L3": "Spine", "T8": "Spine1", "Neck": "Neck", "Head": "Head",
              **{f"{s}{a}": f"{s}{b}" for s in ("Left", "Right")
                 for a, b in (("UpperLeg", "UpLeg"), ("LowerLeg", "Leg"), ("Foot", "Foot"), ("Toe", "ToeBase"),
                              ("Shoulder", "Shoulder"), ("UpperArm", "Arm"), ("ForeArm", "ForeArm"), ("Hand", "Hand"))}},
    "cmu_3dsmax": {"Hips": "Hips", "LHipJoint": "LHipJoint", "RHipJoint": "RHipJoint", "lowerback": "LowerBack",
                   "Chest": "Spine", "Chest2": "Spine1", "lowerneck": "Neck", "Neck": "Neck1", "Head": "Head",
                   **{f"{s}{a}": f"{s}{b}" for s in ("Left", "Right")
                      for a, b in (("Hip", "UpLeg"), ("Knee", "Leg"), ("Ankle", "Foot"), ("Toe", "ToeBase"),
                                   ("Collar", "Shoulder"), ("Shoulder", "Arm"), ("Elbow", "ForeArm"), ("Wrist", "Hand"))}},
}

# (name, motion type, skeleton fixture and its convention, or None for a real file, the source clip
# (dataset clip name) or real file, the written file's frame rate)
SEEDS = (
    ("mixamo_tpose_walk", "walk", ("mixamo_tpose.bvh", "mixamo"), "dataset-2_walk_normal_019", 30),
    ("mixamo_apose_walk", "walk", ("mixamo_apose.bvh", "mixamo"), "dataset-2_walk_masculine_019", 30),
    ("mixamo_apose_jog_tr", "jog", ("mixamo_apose.bvh", "mixamo"), "HDM_tr_jogLeftCircle4StepsRstart_014_120", 30),
    ("xsens_mvn_walk", "walk", ("xsens_mvn.bvh", "xsens"), "dataset-2_walk_active_002", 60),
    ("xsens_mvn_jog", "jog", ("xsens_mvn.bvh", "xsens"), "dataset-2_run_active_023", 60),
    ("cmu_3dsmax_walk", "walk", ("cmu_3dsmax.bvh", "cmu_3dsmax"), "dataset-2_walk_youthful_008", 120),
    ("hdm05_tr_jog", "jog", None, "hdm05/tr/HDM_tr_jogLeftCircle4StepsRstart_015_120.amc", 120),
    ("hdm05_tr_sneak", "sneak", None, "hdm05/tr/HDM_tr_sneak2StepsLStart_014_120.amc", 120),
)


def retargeted_seed(source: Motion, target: Motion, table: dict, fps: float, out: Path) -> Path:
    """``source`` (a motion on the model's joints, CMU names) retargeted onto ``target``'s
    skeleton (:func:`mocapviz.bodies.retarget.retarget` after scaling the source to its leg
    length; ``table``: target joint -> the CMU name it is matched by), written as BVH (the
    target's channels, cm, Y up) at ``fps``."""
    from mocapviz.bodies.retarget import retarget  # imports the body model: only here

    on_cmu_names = target.skeleton.renamed(table)
    scaled = source.scaled(leg_length(on_cmu_names) / leg_length(source.skeleton))
    with warnings.catch_warnings():  # the source's clavicles move: retarget holds them (it says so)
        warnings.simplefilter("ignore")
        moved = retarget(scaled, on_cmu_names)
    motion = Motion(target.skeleton, moved.rotations, moved.root_positions, moved.fps, name=out.stem,
                    meta={"format": "bvh", "length_unit": 0.01, "channels": target.meta["channels"],
                          "root_offset": target.meta["root_offset"]})
    write_bvh(motion.resample(fps), out)
    return out


def build_seeds(ds, folder: Path) -> list[dict]:
    """The :data:`SEEDS` as files in ``folder``: name, path, asf, type and what each is."""
    data, out = find_data_dir(), []
    for name, motion_type, fixture, source, fps in SEEDS:
        if fixture is None:
            path = data / source
            asf = path.parent / f"HDM_{path.parent.name}.asf"
            what = f"real clip of the held-out HDM05 subject ({path.name})"
        else:
            path, asf = retargeted_seed(ds.clip_motion(ds.clip_row(source)), read_bvh(FIXTURES / fixture[0]),
                                        TO_CMU[fixture[1]], fps, folder / f"{name}.bvh"), None
            split = ds.clips.split.values[ds.clip_row(source)]
            what = f"{source} ({split} split) retargeted onto {fixture[0]}, {fps} fps"
        out.append(dict(name=name, path=str(path), asf=None if asf is None else str(asf), type=motion_type, what=what))
    return out


def convention_seeds(ds, folder: Path, norm, meta, source: str = CONVENTION_SOURCE, fps: float = 60.0) -> list[dict]:
    """One seed per exporter convention of ``tests/fixtures/conventions.py`` (17 hand-written
    skeletons: names, nesting, extra and missing joints, A- or T-pose; Z-up ones written Y up
    here), each ``source`` (a test-split Bandai walk) put on it with the library's model-joint
    retargeting through the file's own rig (:func:`mocapviz.tasks.rig.retarget_to`, then
    :meth:`~mocapviz.tasks.rig.ModelRig.from_model`). Why not :func:`retargeted_seed`: on these
    synthetic bodies :func:`mocapviz.bodies.retarget.retarget` tilted the trunk 10 degrees back
    (the walk leaned -8.7 degrees from its rest) and halved the Rigify walk's pace."""
    sys.path.insert(0, str(FIXTURES.parents[1]))  # tests/: the fixtures package
    from fixtures.conventions import CONVENTIONS, bvh_text
    from mocapviz.skeleton_map import map_skeleton
    from mocapviz.tasks.generate_bvh import seed_rig

    motion, out = ds.clip_motion(ds.clip_row(source)), []
    for name, build in CONVENTIONS.items():
        skeleton, _ = build()
        target = read_bvh(f"{name}.bvh", text=bvh_text(skeleton), length_unit=0.01, up="z" if "z_up" in name else "y")
        rig = seed_rig(target, map_skeleton(target.skeleton).mapping, meta["dataset"], norm)
        scaled = motion.scaled(leg_length(rig.skeleton) / leg_length(motion.skeleton))
        moved = rig.from_model(rig.expressible(retarget_to(scaled, rig.skeleton)))
        path = folder / f"{name}.bvh"
        write_bvh(Motion(target.skeleton, moved.rotations, moved.root_positions, moved.fps, name=name,
                         meta={"format": "bvh", "length_unit": 0.01, "channels": target.meta["channels"],
                               "root_offset": target.skeleton.offsets[0]}).resample(fps), path)
        out.append(dict(name=name, path=str(path), asf=None, type="walk",
                        what=f"{source} (test split) on the {name} convention, {fps:g} fps"))
    return out


def lean_degrees(positions: np.ndarray, names) -> np.ndarray:
    """Per frame, the angle (degrees) of the hips -> neck vector from vertical (Y up): ``vert``."""
    v = positions[:, names.index("Neck")] - positions[:, names.index("Hips")]
    return np.degrees(np.arccos(np.clip(v[:, 1] / np.linalg.norm(v, axis=1), -1, 1)))


def lean_spread(ds, motion_type: str) -> tuple[float, float]:
    """5th and 95th percentile, over the dataset's clips of ``motion_type``, of their mean forward
    lean from their skeleton's rest (:func:`mocapviz.metrics.forward_lean`)."""
    rows = np.flatnonzero((ds.clips.type == motion_type).values)
    means = []
    for i in rows:
        m = ds.clip_motion(int(i))
        means.append(metrics.forward_lean(m.positions(), m.skeleton).mean())
    lo, hi = np.percentile(means, LEAN_PERCENTILES)
    return float(lo), float(hi)


def body_numbers(model_motion: Motion, n_seed: int, start: float, stop: float) -> dict:
    """Seed frames [0, n_seed) against generated seconds [start, stop) of a motion on the model's
    joints: the four measures of the module docstring (:func:`posture_of`, both heights above the
    seed's floor), both sides."""
    fps, pos = model_motion.fps, model_motion.positions()
    seed = slice(0, n_seed)
    gen = slice(n_seed + int(round(start * fps)), n_seed + int(round(stop * fps)))
    lowest = pos[:, :, 1].min(axis=1)
    floor = float(np.median(lowest[seed]))
    s = {}
    for key, sl in (("seed", seed), ("gen", gen)):
        s[key] = dict(vars(posture_of(model_motion[sl], floor)),
                      vertical=float(lean_degrees(pos[sl], model_motion.skeleton.names).mean()))
    return dict(seed=s["seed"], gen=s["gen"], speed=s["gen"]["speed"] / s["seed"]["speed"],
                height=s["gen"]["height"] / s["seed"]["height"], lean=s["gen"]["lean"],
                vertical=s["gen"]["vertical"], activity=s["gen"]["activity"] / s["seed"]["activity"],
                feet_cm=100 * (float(np.median(lowest[gen])) - floor))


def passes(r: dict, lean_bar) -> dict:
    ok = {k: bool(lo <= r[k] <= hi) for k, (lo, hi) in BARS.items()}
    ok["lean"] = bool(lean_bar[0] <= r["lean"] <= lean_bar[1])
    ok["seed_lean"] = bool(lean_bar[0] <= r["seed"]["lean"] <= lean_bar[1])  # not a bar: does the seed meet it?
    return ok


def measure(seed_info: dict, model, norm, meta, a, sample: bool, **kw) -> dict:
    seed = load_seed(seed_info["path"], seed_info["asf"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = generate_from_seed(seed, model, norm, meta, types=[seed_info["type"]], seconds=a.seconds,
                                    sample=sample, temperature=a.temperature, pace=a.pace, **kw)
    on_model = result.rig.to_model(result.motion)  # what the BVH holds, on the model's joints
    r = body_numbers(on_model, result.n_seed, a.seconds / 2, a.seconds)
    found = result.z_search  # which code the posture search chose (0: the seed's z), and its probe cost
    r["z_search"] = None if found is None else dict(chosen=found.chosen, cost=float(found.costs[found.chosen]),
                                                    seed_z_cost=float(found.costs[0]))
    return r


def _rest_lean(skeleton) -> float:
    """Forward lean (degrees, + forward) of the hips -> neck vector in a skeleton's rest pose."""
    rest = skeleton.rest_positions()
    v = rest[skeleton.index("Neck")] - rest[skeleton.index("Hips")]
    return float(np.degrees(np.arctan2(v[2], v[1])))


def _block_z(x: np.ndarray, norm) -> dict:
    """Mean |z| (training standard deviations) of raw frame vectors (F, n_x), per block."""
    from mocapviz.features.ccnet import FeatureLayout

    z = np.abs(norm.norm_x(x)[:, :len(norm.x_mean)])
    blocks = FeatureLayout((x.shape[1] - 6) // 12).x_blocks
    return {k: float(z[:, b].mean()) for k, b in blocks.items() if k != "contact"}


def diagnose(seeds: list[dict], model, norm, meta, ds, a) -> None:
    """Why a Mixamo body shuffled bent over: the c^s it gets, the --skeleton-z clamp, the rest
    offset from the training rest, and the body the network generates on (printed)."""
    from mocapviz.features.ccnet import motion_features
    from mocapviz.skeleton_map import map_skeleton
    from mocapviz.tasks.generate_bvh import generation_body, seed_rig, seen_scale

    dsm, fps = meta["dataset"], float(meta["dataset"]["fps"])
    labels = ["root height"] + [f"{n}.{c}" for n in dsm["joint_names"][1:] for c in "xyz"]
    for info in seeds:
        seed = load_seed(info["path"])
        seed60 = seed.resample(fps)[:int(round(2 * fps))]
        rig = seed_rig(seed60, map_skeleton(seed60.skeleton).mapping, dsm, norm)
        on_model = rig.to_model(seed60)
        cs = on_model.skeleton.configuration()
        z = (cs - norm.skel_mean) / norm.skel_std
        top = np.argsort(-np.abs(z))[:5]
        print(f"\n== {info['name']} ({info['what']})")
        print(f"c^s: root height {cs[0]:.3f} m (training {norm.skel_mean[0]:.3f} +- {norm.skel_std[0]:.3f}: "
              f"z {z[0]:+.2f}, seen at scale {seen_scale(cs[0], norm, 3.0):.3f}); |z| max {np.abs(z).max():.1f}, "
              f"rms {np.sqrt((z ** 2).mean()):.2f}, {(np.abs(z) > 3).sum()} of {len(z)} values beyond the --skeleton-z 3 "
              f"clamp; largest: " + ", ".join(f"{labels[i]} {cs[i]:+.3f} m (mean {norm.skel_mean[i]:+.3f}, z {z[i]:+.1f})"
                                              for i in top))
        angles = np.degrees(np.arccos(np.clip((np.trace(rig.align, axis1=1, axis2=2) - 1) / 2, -1, 1)))
        names = dsm["joint_names"]
        print("rest offset from the training rest (the rig's alignment A_c, degrees): "
              + ", ".join(f"{names[c]} {angles[c]:.0f}" for c in range(len(names))
                          if rig.source[c] >= 0 and angles[c] >= 5)
              + f"; rest lean of the hips -> neck vector {_rest_lean(on_model.skeleton):+.1f} (training body "
              f"{_rest_lean(generation_body(rig, dsm, 'training')):+.1f})")
        zs = _block_z(motion_features(on_model, fps).x, norm)
        body = generation_body(rig, dsm, "training")
        zb = _block_z(motion_features(retarget_to(on_model, body), fps).x, norm)
        source = {n: src for n, _, fixture, src, _ in SEEDS if fixture is not None}.get(info["name"])
        row = None if source is None else ds.clip_row(source)
        line = ("seed frame vectors, mean |z| per block: on its own body " + " ".join(f"{k} {v:.2f}" for k, v in zs.items())
                + "; on the training body " + " ".join(f"{k} {v:.2f}" for k, v in zb.items()))
        if row is not None:
            r = ds.clips.iloc[row]
            zd = _block_z(ds.x[int(r.start):int(r.start) + len(on_model.rotations) - 1], norm)
            line += "; the source take as the dataset holds it " + " ".join(f"{k} {v:.2f}" for k, v in zd.items())
        print(line)
        print("generated (seconds %g-%g, mean output): pace, height, lean, activity, feet cm" % (a.seconds / 2, a.seconds))
        for label, kw in (("own body, --skeleton-z 3 (before)", dict(body="own", ground=False, skeleton_z=3.0)),
                          ("own body, --skeleton-z 0", dict(body="own", ground=False, skeleton_z=0.0)),
                          ("own body, --skeleton-z inf", dict(body="own", ground=False, skeleton_z=float("inf"))),
                          ("own body, grounded", dict(body="own", ground=True)),
                          ("training body, not grounded", dict(body="training", ground=False)),
                          ("training body, grounded (now)", dict(body="training", ground=True))):
            r = measure(info, model, norm, meta, a, False, **kw)
            print(f"  {label:34s} {r['speed']:5.2f}x {r['height']:6.3f} {r['lean']:5.1f} {r['activity']:5.2f}x "
                  f"{r['feet_cm']:+6.1f}")
    print()


def _fmt_row(name, mode, r, ok, lean_bar, secs) -> str:
    mark = lambda k: "ok" if ok[k] else "FAIL"  # noqa: E731
    return (f"{name:20s} {mode:7s} {r['seed']['speed']:5.2f} {r['gen']['speed']:5.2f} {r['speed']:5.2f}x {mark('speed'):4s} "
            f"{100 * r['seed']['height']:5.1f} {100 * r['gen']['height']:5.1f} {r['height']:6.3f} {mark('height'):4s} "
            f"{r['feet_cm']:+6.1f}  {r['seed']['lean']:+5.1f}{' ' if ok['seed_lean'] else '*'}{r['lean']:+5.1f} [{lean_bar[0]:4.1f},{lean_bar[1]:4.1f}] "
            f"{mark('lean'):4s} {r['vertical']:5.1f} {r['activity']:5.2f}x {mark('activity'):4s} "
            f"{'-' if r['z_search'] is None else r['z_search']['chosen']:>3} ({secs:.0f} s)")


HEADER = (f"{'seed':20s} {'mode':7s} {'m/s':>5s} {'gen':>5s} {'pace':>6s} {'':4s} {'h cm':>5s} {'gen':>5s} {'height':>6s} "
          f"{'':4s} {'feet':>6s}  {'lean':>5s} {'gen':>5s} {'bar':>11s} {'':4s} {'vert':>5s} {'activ':>6s} {'':4s} {'z':>3s}")


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("files", nargs="*", help="FILE.bvh:TYPE (default: the built seeds)")
    p.add_argument("--model", default=GENERATION_MODEL)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--modes", default="mean,sampled", help="mean, sampled or both (comma-separated)")
    p.add_argument("--sample", action="store_true", help="the sampled output only (--modes sampled)")
    p.add_argument("--temperature", type=float, default=SAMPLING_TEMPERATURE)
    p.add_argument("--pace", choices=PACES, default=PACE)
    p.add_argument("--body", choices=BODIES, help="generate_from_seed(body=...): the body the network generates on "
                   "(default: the command's, auto)")
    p.add_argument("--no-ground", action="store_true", help="generate_from_seed(ground=False)")
    p.add_argument("--z-source", choices=Z_SOURCES, default=Z_SOURCE, help="generate_from_seed(z_source=...)")
    p.add_argument("--z-search", type=int, default=Z_SEARCH, help="generate_from_seed(z_search=...): codes tried "
                   "around the seed's z (0: the seed's z as read; default: the command's, %(default)s)")
    p.add_argument("--diagnose", action="store_true", help="first print why a Mixamo body shuffled bent over")
    p.add_argument("--keep", help="write the built seeds here (default: a temporary folder)")
    p.add_argument("--only", help="comma-separated seed names to run")
    p.add_argument("--conventions", action="store_true", help="instead of the built seeds: a Bandai test walk on each "
                   "of the 17 exporter conventions of tests/fixtures/conventions.py")
    a = p.parse_args(argv)
    torch.set_num_threads(1)
    model, norm, meta = load_checkpoint(find_checkpoint(a.model))
    ds = build_dataset(DatasetConfig(), progress=False)
    kw = dict(z_source=a.z_source, z_search=a.z_search)
    if a.body:
        kw["body"] = a.body
    if a.no_ground:
        kw["ground"] = False
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(a.keep or tmp)
        folder.mkdir(parents=True, exist_ok=True)
        if a.files:
            seeds = [dict(name=Path(f.rsplit(":", 1)[0]).stem, path=f.rsplit(":", 1)[0], asf=None, type=f.rsplit(":", 1)[1],
                          what="a file given") for f in a.files]
        elif a.conventions:
            seeds = convention_seeds(ds, folder, norm, meta)
        else:
            seeds = build_seeds(ds, folder)
        if a.only:
            seeds = [s for s in seeds if s["name"] in a.only.split(",")]
        for s in seeds:
            print(f"{s['name']:20s} {s['type']:6s} {s['what']}")
        if a.diagnose:
            diagnose([s for s in seeds if s["name"].startswith("mixamo")], model, norm, meta, ds, a)
        spreads = {t: lean_spread(ds, t) for t in sorted({s["type"] for s in seeds})}
        print("lean bars (5th-95th percentile of the dataset's clips' mean forward lean from their rest, degrees): "
              + ", ".join(f"{t} {lo:.1f}-{hi:.1f}" for t, (lo, hi) in spreads.items()))
        modes = ["sampled"] if a.sample else a.modes.split(",")
        print(HEADER)
        per_seed, passed = {}, {m: 0 for m in modes}
        for s in seeds:
            per_seed[s["name"]] = {"type": s["type"], "what": s["what"]}
            for mode in modes:
                t = time.perf_counter()
                r = measure(s, model, norm, meta, a, mode == "sampled", **kw)
                ok = passes(r, spreads[s["type"]])
                r["pass"], r["all"] = ok, all(v for k, v in ok.items() if k != "seed_lean")
                passed[mode] += r["all"]
                per_seed[s["name"]][mode] = r
                print(_fmt_row(s["name"], mode, r, ok, spreads[s["type"]], time.perf_counter() - t), flush=True)
    bars_met = {k: {m: sum(per_seed[n][m]["pass"][k] for n in per_seed) for m in modes}
                for k in ("speed", "height", "lean", "activity")}
    print("bars met (of %d seeds): " % len(per_seed)
          + "; ".join(f"{k} " + ", ".join(f"{m} {v}" for m, v in d.items()) for k, d in bars_met.items()))
    outside = [n for n in per_seed if not per_seed[n][modes[0]]["pass"]["seed_lean"]]
    print("seeds that lean outside their own type's bar: " + (", ".join(outside) or "none"))
    lean_gap = max(abs(per_seed[n][m]["lean"] - per_seed[n][m]["seed"]["lean"]) for n in per_seed for m in modes)
    print(f"generated lean from the seed's, largest over seeds and modes: {lean_gap:.1f} degrees")
    res = dict(model=a.model, seconds=a.seconds, window=[a.seconds / 2, a.seconds], temperature=a.temperature,
               pace=a.pace, z_source=a.z_source, z_search=a.z_search, body=a.body or "auto", ground=not a.no_ground, bars=BARS,
               lean_bars=spreads, passed=passed, bars_met=bars_met, seeds_outside_lean_bar=outside, lean_from_seed_max=lean_gap,
               n_seeds=len(per_seed), seeds=per_seed)
    print(json.dumps(res))
    return res


if __name__ == "__main__":
    main()
