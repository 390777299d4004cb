"""Generate motion from a user's own seed file and write it on the user's skeleton (BVH).

The seed (BVH, or ASF/AMC) loses a leading inserted T-pose frame
(:func:`mocapviz.io.tpose.leading_tpose_frames`), is resampled to the model's 60 fps and cut
to ``seed_seconds``; its skeleton is mapped onto the model's joints
(:func:`mocapviz.skeleton_map.map_skeleton`: by a naming convention's table, else from the tree
and the rest pose; :class:`mocapviz.tasks.rig.ModelRig`) and aligned to
the mean rest pose of the training skeletons; that rest pose with the file's own bone lengths
gives c^s. A body the training data did not have is retargeted onto the training body at its
leg length, generated there and retargeted back (:func:`generate_from_seed` says why).
:class:`mocapviz.tasks.generate.Generator` continues the seed; the generated frames, their
feet on the seed's floor (:func:`grounded`), go back onto the seed's skeleton (all its joints
and names) and follow the seed frames in the output. A seed may be as short as one frame (with a
:class:`ShortSeedWarning` under the receptive field: the paper's zero padding before the seed).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mocapviz.features.ccnet import TRAJ_STEPS, FeatureLayout, heading_angles, motion_features
from mocapviz.features.ccnet_joints import CCNET_25_PARENTS, T_POSE_DIRECTIONS, known_alignment
from mocapviz.features.motion_types import one_hot
from mocapviz.io.asfamc import read_amc
from mocapviz.io.bvh import read_bvh
from mocapviz.io.tpose import leading_tpose_frames
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton, SkeletonMapError
from mocapviz.skeleton_map import map_skeleton
from mocapviz.tasks.controls import PathControls
from mocapviz.tasks.generate import Generator
from mocapviz.tasks.generation_defaults import (PACE, SAMPLING_TEMPERATURE, Z_SEARCH, Z_SEARCH_SECONDS,
                                                Z_SEARCH_SPREADS, Z_SOURCE)
from mocapviz.tasks.posture_search import MIN_SEED_SECONDS, ZSearch, posture_of, search_seed_z
from mocapviz.tasks.rig import ModelRig, floor_height, grounded, known_body, leg_length, retarget_to

BODIES = ("auto", "own", "training")  # what generate_from_seed(body=...) accepts
STANDARD_ORDERS = ("ZXY", "ZYX")  # rotation channel orders every BVH tool reads (Blender, MotionBuilder)
CENTIMETRE = 0.01


class GenerateError(ValueError):
    """A request the command cannot carry out; the message says what to change."""


class ShortSeedWarning(UserWarning):
    """The seed is shorter than the model's receptive field + 1 frames: the first generated
    frames are generated from less context (the causal network's zero padding before the seed)."""


def _need_file(path, what: str) -> Path:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    return path


def read_json(path, what: str):
    """The JSON value in file ``path`` (None for no path)."""
    if path is None:
        return None
    try:
        return json.loads(_need_file(path, what).read_text())
    except json.JSONDecodeError as e:
        raise GenerateError(f"{what} {path} is not JSON: {e}") from None


def load_seed(path, asf=None, fps: float = 120.0, up: str = "y") -> Motion:
    """A seed file as a Motion (metres, Y up) without a leading inserted T-pose frame.

    ``path``: a BVH, or an AMC with its ``asf``; ``fps``: the AMC's frame rate (AMC files do
    not say); ``up``: the file's up axis ("y", "z" or "auto"). ``meta['tpose_frames']`` says
    how many leading frames were dropped.
    """
    path = _need_file(path, "seed file")
    if path.suffix.lower() == ".amc":
        if asf is None:
            raise GenerateError(f"{path} is an AMC file: pass its skeleton with --asf FILE.asf")
        motion = read_amc(path, _need_file(asf, "ASF file"), fps=fps, up=up)
    elif path.suffix.lower() == ".bvh":
        motion = read_bvh(path, up=up)
    else:
        raise GenerateError(f"{path}: a seed is a .bvh file, or an .amc file with --asf")
    skip = leading_tpose_frames(motion)
    motion = motion[skip:]
    motion.meta["tpose_frames"] = skip
    return motion


def mean_rest(normaliser) -> np.ndarray:
    """Rest joint positions (J, 3) of the mean training skeleton, root at the origin: the mean
    c^s without its first value, the root height (layout of :meth:`Skeleton.configuration`)."""
    return np.concatenate([np.zeros(3), np.asarray(normaliser.skel_mean[1:], dtype=np.float64)]).reshape(-1, 3)


def rotation_stats(normaliser, n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """Training mean and standard deviation (J, 3) of each joint's local exp map (the frame
    vector's ``rot`` block; the root's is relative to its heading)."""
    rot = FeatureLayout(n_joints).x_blocks["rot"]
    return (np.asarray(normaliser.x_mean[rot], dtype=np.float64).reshape(n_joints, 3),
            np.asarray(normaliser.x_std[rot], dtype=np.float64).reshape(n_joints, 3))


@dataclass
class SeedGeneration:
    motion: Motion          # the seed's skeleton: seed frames, then generated ones (model fps)
    n_seed: int             # how many of its frames are the seed's
    model_motion: Motion    # the generated frames on the model's skeleton (what the rig maps back)
    rig: ModelRig
    z_search: ZSearch | None = None  # the search for z after the seed, where one ran (posture_search)


def type_schedule(types, known, n_seed: int, n_gen: int, switch_every: float | None, fps: float) -> np.ndarray:
    """One-hot motion types (n_seed + n_gen, n_types): the seed frames and the first
    ``switch_every`` seconds of generation take ``types[0]``, then each next type in turn."""
    unknown = [t for t in types if t not in known]
    if unknown:
        raise GenerateError(f"unknown motion type {unknown[0]!r}; known: {', '.join(known)}")
    if len(types) > 1 and not switch_every:
        raise GenerateError(f"{len(types)} motion types need --switch-every SECONDS")
    idx = np.zeros(n_seed + n_gen, dtype=np.int64)
    if len(types) > 1:
        period = max(1, int(round(switch_every * fps)))
        idx[n_seed:] = (np.arange(n_gen) // period) % len(types)
    return one_hot([list(known).index(types[i]) for i in idx], len(known))


def path_points(path_xz, n_gen: int) -> np.ndarray:
    """``path_xz`` (N, 2) resampled to one point per generated frame (n_gen, 2), linearly
    along the point index (N == n_gen keeps them as given)."""
    path_xz = np.asarray(path_xz, dtype=np.float64)
    if path_xz.ndim != 2 or path_xz.shape[1] != 2 or len(path_xz) < 2:
        raise GenerateError(f"a path is a list of at least two [x, z] points, got shape {path_xz.shape}")
    at = np.linspace(0, len(path_xz) - 1, n_gen)
    return np.stack([np.interp(at, np.arange(len(path_xz)), path_xz[:, k]) for k in (0, 1)], axis=1)


def seed_rig(seed: Motion, names: dict, dataset_meta: dict, normaliser) -> ModelRig:
    """The rig that maps ``seed``'s skeleton (file joint -> model joint ``names``) onto the
    model's joints. A file with every model joint (a VICON skeleton, as HDM05's and CMU's) keeps
    its own rest pose, as the training data did: aligned to the mean training rest instead, a
    CMU walk's rotations came out 0.8 standard deviations from the dataset's for the same file.
    A skeleton the training data had under another rest (Bandai's) takes the dataset's re-basing
    (:func:`mocapviz.features.ccnet_joints.known_alignment`): aligned to the mean training rest
    instead, a Bandai walk's rotations came out 1.1 standard deviations from the dataset's.
    Other skeletons, and one with every model joint whose legs do not rest as the VICON
    skeletons' (:func:`vicon_legs`: a 3ds-Max-style CMU hierarchy written with straight legs),
    are aligned to the mean training rest (:class:`ModelRig`)."""
    joints = dataset_meta["joint_names"]
    if set(names.values()) == set(joints) and vicon_legs(seed.skeleton, names):
        return ModelRig(seed, names, joints, dataset_meta["parents"])
    known = known_alignment(seed.skeleton, names)
    if known is not None:
        return ModelRig(seed, names, joints, dataset_meta["parents"], alignment=known)
    return ModelRig(seed, names, joints, dataset_meta["parents"], canonical_rest=mean_rest(normaliser),
                    rotation_stats=rotation_stats(normaliser, len(joints)))


def vicon_legs(skeleton, names: dict, tol_degrees: float = 10.0) -> bool:
    """Whether thighs and shins of ``skeleton`` (file joint -> model joint ``names``) rest as
    the VICON skeletons of the training data (splayed 20 degrees, :data:`T_POSE_DIRECTIONS`)
    within ``tol_degrees``. Every CMU and HDM05 skeleton here does to 0.001 degrees; their
    clavicles and lower backs do not (up to 41 degrees off the training rest's straight lines),
    so legs are what is checked. A file whose legs rest straight down would keep a 20-degree
    offset in every leg rotation with its own rest."""
    by_model = {m: f for f, m in names.items()}
    rest = skeleton.rest_positions()
    for joint in ("LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg"):
        child = next(c for c, p in CCNET_25_PARENTS.items() if p == joint)
        bone = rest[skeleton.index(by_model[child])] - rest[skeleton.index(by_model[joint])]
        cos = bone @ np.asarray(T_POSE_DIRECTIONS[joint]) / max(np.linalg.norm(bone), 1e-9)
        if np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) > tol_degrees:
            return False
    return True


def generation_body(rig: ModelRig, dataset_meta: dict, body: str = "auto"):
    """The skeleton (model joints) the network generates on for a seed on ``rig``, or None for
    the seed's own (:func:`generate_from_seed`, ``body``): "own"; "training": the training body
    (:func:`mocapviz.tasks.rig.known_body`, Bandai's) scaled to the seed's leg length; "auto":
    the training body, unless the seed is on it already (offsets within 1 % of the leg length).

    Why "auto" takes the training body for the VICON skeletons too (HDM05's and CMU's, which the
    training data had, for 10 % of its frames): on its own body the held-out HDM05 subject tr's
    jog came out upright (forward lean +0.8 degrees from its rest against real jogs' 4.8-17.8,
    the seed's +24.6) and its sneak at 1.59x the seed's pace; on the training body the same jog
    leans +9.4 and the sneak keeps 0.99x its pace (``benchmarks/bench_generate_files.py --body
    own|training``, docs/your_own_file.md)."""
    if body not in BODIES:
        raise GenerateError(f"body is one of {', '.join(BODIES)}, got {body!r}")
    if body == "own":
        return None
    trained = known_body(dataset_meta["joint_names"], dataset_meta["parents"])
    leg = leg_length(rig.skeleton)
    k = leg / leg_length(trained)
    scaled = Skeleton(trained.names, trained.parents, k * trained.offsets,
                      tuple((j, tuple(k * np.asarray(o))) for j, o in trained.end_sites))
    if body == "auto" and np.abs(np.asarray(rig.skeleton.offsets) - scaled.offsets).max() < 0.01 * leg:
        return None
    return scaled


def generate_from_seed(seed: Motion, model, normaliser, meta: dict, types=("walk",), seconds: float = 10.0,
                       switch_every: float | None = None, path_xz=None, sample: bool = False, ik: bool = True,
                       seed_seconds: float = 2.0, joint_map=None, rng_seed: int = 0, skeleton_z: float = 3.0,
                       temperature: float = SAMPLING_TEMPERATURE, noise_correlation: float = 0.0,
                       pace: str = PACE, body: str = "auto", ground: bool = True, z_source: str = Z_SOURCE,
                       z_search: int = Z_SEARCH, progress: bool = False) -> SeedGeneration:
    """Continue ``seed`` (a Motion on any skeleton, e.g. from :func:`load_seed`) for ``seconds``.

    ``model``, ``normaliser``, ``meta``: a loaded checkpoint (its ``meta['dataset']`` gives the
    joints, fps and motion types); ``types``: motion type names, switched every
    ``switch_every`` seconds; ``path_xz`` (N, 2): ground points in metres (world X, Z) relative
    to the seed's last root position, resampled to one per generated frame (default: the
    network's own trajectory); ``joint_map``: file joint -> CCNet joint (dict or JSON file),
    over the automatic map (names, else the tree); ``skeleton_z``: how far (training standard deviations) c^s
    may lie from the training skeletons' mean (see :func:`limit_skeleton`); ``temperature``:
    with ``sample``, frames are drawn from N(mean, (temperature * sigma)^2) (a latent model
    draws z instead); ``noise_correlation``: the draws' correlation from frame to frame;
    ``pace``: without a path, "seed" holds the seed's pace (the speed of its last second), "network"
    feeds the network's own plan as predicted (:class:`mocapviz.tasks.generate.Generator`);
    ``body``: the skeleton the network generates on (:func:`generation_body`): "auto" (the
    training body, scaled to the seed's legs, unless the seed is on it already; the result is
    retargeted back), "own", or "training" (every seed on the training body, for comparisons);
    ``ground``: keep the generated body's feet on the seed's floor (:func:`grounded`); ``z_source``:
    a latent model's z after the seed, "seed" (read from the seed's own frames) or "type" (the
    motion type's prior; :class:`mocapviz.tasks.generate.Generator`); ``z_search``: with z from the
    seed, try this many codes a round around it (two rounds) and generate with the one whose 8 s
    rollout keeps the seed's root height, lean, pace and activity best
    (:mod:`mocapviz.tasks.posture_search`; 0 or 1: the seed's z as read; seeds under 0.5 s are not
    searched).

    Any seed of one frame or more: one shorter than the model's receptive field + 1 frames
    warns (:class:`ShortSeedWarning`) and is fed as it is, the network seeing zeros before it
    as the paper's causal CCNet does (:func:`seed_features` says what short seeds fall back on).

    The network sees the seed scaled into the training skeletons' root heights (:func:`seen_scale`;
    the output is scaled back) and its c^s limited to ``skeleton_z`` (:func:`limit_skeleton`): a
    model trained on ~20 VICON skeletons crouched to half height from a Bandai seed's own c^s
    (10 standard deviations out at the hips) and stood with it limited to 3.

    A body other than the training body (Mixamo, Xsens MVN, a 3ds-Max-style CMU hierarchy, the
    VICON skeletons of HDM05 and CMU) is not generated on at all: the seed's
    motion goes onto the training body scaled to the seed's leg length (Bandai's, 90 % of the
    training frames: :func:`mocapviz.tasks.rig.known_body`) with the library's retargeting and
    leg IK (:func:`mocapviz.tasks.rig.retarget_to`), the network continues it there with that
    body's c^s, and the generated frames come back the same way. Why: on its own body a
    Mixamo-proportioned walk (torso 8 cm longer, root 7 cm above the hip joints) shuffled at
    0.12x the seed's ground speed, 7.9 cm into the floor and crouched, although its c^s lay
    within the ``skeleton_z`` clamp but for one value (``--skeleton-z`` inf changed nothing;
    0, c^s at the training mean under the body's own frame vectors, ran at 3.4x) and its
    rotations, aligned to the training rest, were as near the training statistics as the
    source take's (0.44 vs 0.42 mean |z|): the body's joint positions were not (0.89 vs
    0.36). On the training body it walks at 1.18x (``benchmarks/bench_generate_files.py
    --diagnose``). The generated root's height is then held to the seed's floor
    (:func:`grounded`): on their own bodies the held-out VICON subject's jog sank 19 cm into
    the floor with its legs straight, CMU 35_01's walk 18 cm (the network's root height keeps
    near the training body's whatever the c^s).
    """
    ds = meta["dataset"]
    fps, known = float(ds["fps"]), tuple(ds["motion_types"])
    need = model.cfg.receptive_field + 1  # frame vectors start at the second frame
    try:
        names = map_skeleton(seed.skeleton, joint_map, source=seed.meta.get("source", "")).mapping
    except SkeletonMapError as e:
        hint = "" if "--joint-map" in str(e) else " (on the command line: --joint-map FILE.json)"
        raise GenerateError(f"{e}{hint}") from None
    if seed.n_frames < 1:
        raise GenerateError("the seed has no frames")
    seed60 = seed if abs(seed.fps - fps) < 1e-6 else seed.resample(fps)
    n_seed = min(seed60.n_frames, int(round(seed_seconds * fps)))
    if n_seed < 1:
        raise GenerateError(f"--seed-seconds {seed_seconds:g} keeps no frame of the seed: give at least "
                            f"{1 / fps:.3f} s (one frame at {fps:g} fps)")
    if n_seed < need:
        warnings.warn(ShortSeedWarning(
            f"the seed is shorter than the model's receptive field: {n_seed} frame{'s' * (n_seed != 1)} at {fps:g} fps "
            f"({n_seed / fps:.2f} s), the model looks back {need} ({need / fps:.2f} s, its receptive field + 1); "
            f"the first frames are generated from less context"), stacklevel=2)
    seed60 = seed60[:n_seed]
    rig = seed_rig(seed60, names, ds, normaliser)
    seed_m = rig.to_model(seed60)
    floor = floor_height(seed_m.positions())
    seed_own = seed_m  # on the user's own body, where the posture search measures
    on_body = generation_body(rig, ds, body)
    if on_body is not None:  # the seed's motion on the body the network generates on
        seed_m = retarget_to(seed_m, on_body)
    # the network knows the sizes of its training skeletons only: it sees the seed scaled into
    # their root heights (within skeleton_z standard deviations of their mean; a seed inside
    # stays as it is), and c^s within skeleton_z standard deviations of their mean
    size = seen_scale(seed_m.skeleton.configuration()[0], normaliser, skeleton_z)
    seen = seed_m.scaled(size)
    feats, seen_root = seed_features(seen, fps)
    n_gen = int(round(seconds * fps))
    types_oh = type_schedule(list(types), known, len(feats.x), n_gen, switch_every, fps)
    theta = heading_angles(seen.positions(), seen.skeleton)
    end_root, end_heading = seen.root_positions[-1], float(theta[-1])
    skel_seen = limit_skeleton(feats.skel, normaliser, skeleton_z)
    searched = None
    if z_source == "seed" and n_seed >= MIN_SEED_SECONDS * fps:
        searched = search_seed_z(model, normaliser, feats.x, skel_seen, types_oh[0], seed_controls(feats.traj),
                                 seen.skeleton, posture_of(seed_own), candidates=z_search, seconds=Z_SEARCH_SECONDS,
                                 spreads=Z_SEARCH_SPREADS, pace=pace, rng_seed=rng_seed, ik=ik, progress=progress,
                                 to_target_body=lambda m: _on_user_body(m, size, on_body, rig))
    controls = None  # the network's own plan, at the pace asked for
    if path_xz is not None:
        ahead = path_points(path_xz, n_gen) * size + end_root[[0, 2]]
        controls = PathControls(np.concatenate([seen_root[:, [0, 2]], ahead])[None], feats.start_root[None],
                                np.array([feats.start_heading]))
    gen = Generator(model, normaliser, sample=sample, seed=rng_seed, temperature=temperature,
                    noise_correlation=noise_correlation, pace=pace, z_source=z_source,
                    z_shift=None if searched is None else searched.shift[None]).run(
        feats.x[None], skel_seen[None], types_oh[None], n_gen, controls,
        seed_traj=seed_controls(feats.traj)[None], progress=progress)
    gen_m = _on_user_body(gen.motion(0, seen.skeleton, start_root=end_root, start_heading=end_heading, ik=ik,
                                     include_seed=False), size, on_body, rig)
    if ground:
        gen_m = grounded(gen_m, floor)
    out = _concat(seed60, rig.from_model(gen_m))
    return SeedGeneration(out, n_seed, gen_m, rig, searched)


def _on_user_body(generated: Motion, size: float, on_body, rig: ModelRig) -> Motion:
    """Generated frames (model joints, at the scale the network saw) at the seed's size, back on
    the seed's own body where they were generated on another (``on_body``), as the file can show them."""
    m = generated.scaled(1 / size)
    if on_body is not None:
        m = retarget_to(m, rig.skeleton)
    return rig.expressible(m)


def seed_features(seen: Motion, fps: float):
    """The frame vectors and controls of a seed (model joints, ``fps``) and the root positions
    (n, 3) of the frames they describe: ``max(1, F - 1)`` frame vectors for F seed frames.

    A frame vector holds velocities, so the first frame of a seed only starts the second's; a
    seed of one or two frames gets its first frame held still before it (F = 1: one frame
    vector, the pose at rest: no velocity, both feet down where they are lowest). Nothing
    else is padded: before the seed the network's inputs are zero (the stepper's buffers start
    at zero, the causal padding of the paper's CCNet), and a phase model's phase turns on at the
    motion type's usual pace where the seed is too short to show a cycle
    (:func:`mocapviz.features.phase.seed_phase`). A one-frame seed has no plan (c^d) at its
    end for pace "seed" to hold: the network's own plan drives it from its first prediction."""
    n = seen.n_frames
    padded = seen if n >= 3 else _held_first(seen, 3 - n)
    feats = motion_features(padded, fps)
    keep = max(1, n - 1)
    if keep < len(feats.x):
        theta = heading_angles(padded.positions(), padded.skeleton)
        first = len(padded.root_positions) - keep - 1  # the frame before the first kept vector
        feats = replace(feats, x=feats.x[-keep:], traj=feats.traj[-keep:],
                        start_root=padded.root_positions[first].copy(), start_heading=float(theta[first]))
    return feats, padded.root_positions[-keep:]


def _held_first(motion: Motion, k: int) -> Motion:
    """``motion`` with its first frame repeated ``k`` more times before it."""
    idx = np.concatenate([np.zeros(k, dtype=np.int64), np.arange(motion.n_frames)])
    trans = {j: t[idx] for j, t in motion.translations.items()}
    return replace(motion, rotations=motion.rotations[idx], root_positions=motion.root_positions[idx],
                   translations=trans)


def seed_controls(traj: np.ndarray) -> np.ndarray:
    """The seed's c^d (F, 12) with NaN rows (the Generator's own c^d: its prediction, or the
    path's) where a frame's look-ahead passes the seed's last frame. Why: there the seed knows no
    future and :func:`~mocapviz.features.ccnet.trajectory_control` extrapolates it at the last
    0.25 s velocity, which no training window shows: a Bandai walk's first 2 s seed with the
    extrapolated c^d ran at 3.4 m/s for a minute, with the network's own c^d in its last second
    it walked at 1.36 (the same as with the take's true future; the take walks at 1.46)."""
    traj = traj.copy()
    traj[max(0, len(traj) - TRAJ_STEPS[-1]):] = np.nan
    return traj


def seen_scale(root_height: float, normaliser, z: float) -> float:
    """The factor that brings a seed's standing root height (m) within ``z`` training standard
    deviations of the training skeletons' mean (1 for a seed already within). Why not scale
    every seed to the mean: a model trained on one Bandai skeleton for 90 % of its frames reads
    c^s to the hundredth; scaled by 1.009 (c^s moved 1.4 standard deviations), a Bandai walk
    seed walked at 3.2 m/s instead of 1.3 (the phase model without a latent) and at
    1.36 m/s instead of 1.01 (ccnet_phase)."""
    mean, std = float(normaliser.skel_mean[0]), float(normaliser.skel_std[0])
    return float(np.clip(root_height, mean - z * std, mean + z * std) / root_height)


def limit_skeleton(skel: np.ndarray, normaliser, z: float) -> np.ndarray:
    """c^s (n_skel,) clipped to within ``z`` training standard deviations of the training
    mean, per value (``z = 0``: the mean training skeleton; ``inf``: unchanged)."""
    dev = np.clip((skel - normaliser.skel_mean) / normaliser.skel_std, -z, z)
    return (normaliser.skel_mean + dev * normaliser.skel_std).astype(np.float32)


def _concat(seed: Motion, generated: Motion) -> Motion:
    """Seed frames then generated frames, one skeleton; meta says how to write the file."""
    trans = {j: np.concatenate([seed.translations[j], generated.translations[j]]) for j in generated.translations}
    meta = {"length_unit": seed.meta.get("length_unit", CENTIMETRE) if seed.meta.get("format") == "bvh"
            else CENTIMETRE, "source": seed.meta.get("source", "")}
    if "channels" in seed.meta:
        meta["channels"] = _standard_channels(seed.meta["channels"])
        meta["root_offset"] = seed.meta.get("root_offset", np.zeros(3))
    return Motion(seed.skeleton, np.concatenate([seed.rotations, generated.rotations]),
                  np.concatenate([seed.root_positions, generated.root_positions]), seed.fps,
                  name=seed.name + "_generated", meta=meta, translations=trans)


def _standard_channels(channels: list[list[str]]) -> list[list[str]]:
    """The seed file's channel layout, position channels on the root, rotation orders other
    than ZXY/ZYX written as ZYX."""
    out = []
    for j, chans in enumerate(channels):
        pos = [c for c in chans if c.endswith("position")] or (["xposition", "yposition", "zposition"] if j == 0 else [])
        rot = [c for c in chans if c.endswith("rotation")]
        order = "".join(c[0].upper() for c in rot)
        if rot and order not in STANDARD_ORDERS:
            rot = ["zrotation", "yrotation", "xrotation"]
        out.append(pos + rot)
    return out
