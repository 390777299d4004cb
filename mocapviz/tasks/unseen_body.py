"""CCNet paper §4.6, Figs. 9-10: generating for a body no one captured ("7b").

The paper scales the lower body of its unseen subject 7 by 0.8 ("7b"), retargets motion capture
onto it for 120 seed frames and shows CCNet walking and following a trajectory with that body;
ERD-4LR and PFNN, it says, show "large, sharp changes between the seed frames and generated
frames", and the baselines' feet go into the ground (Fig. 9). Ours:

- the unseen subject is HDM05's ``tr`` (the dataset's held-out test subject); 7b is each tr clip's
  skeleton with its legs scaled (:func:`scaled_lower_body`);
- the seeds are tr's locomotion clips long enough for 120 frames (:func:`seed_rows`: the four
  ``jogLeftCircle`` clips; tr's sneaks are 94-99 frames), retargeted onto 7b with the library's
  retargeting and leg IK (:func:`retarget_seed`); :func:`body_dataset` holds them as dataset rows
  (frame vectors, c^d and c^s of 7b, :func:`mocapviz.features.ccnet.motion_features`);
- 7b's c^s goes to the networks as it is (no clamp to the training skeletons, unlike the generate
  command's :func:`~mocapviz.tasks.generate_bvh.limit_skeleton`): the paper's test of whether a
  network reads c^s;
- walking: :func:`walk`, the seed then ``seconds`` of type walk (the label blended from the
  seed's type over 20 frames, as the trajectory task's type changes are), the network's own c^d;
- trajectory following: :func:`mocapviz.tasks.trajectory_following.follow` on the 7b rows;
- measured on the networks' own poses (no foot IK): :func:`seam_jump` (the sharp change at
  the seam) and :func:`foot_ground` (feet under or above the seed's floor, Fig. 9's point).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from mocapviz import metrics
from mocapviz.features.ccnet import FPS, heading_angles, motion_features
from mocapviz.features.motion_types import MOTION_TYPES, one_hot
from mocapviz.heading import to_heading_frame
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton
from mocapviz.tasks import trajectory_following as tf
from mocapviz.tasks.generate import Generated, Generator
from mocapviz.tasks.generate_bvh import generate_from_seed, seed_controls
from mocapviz.tasks.rig import floor_height, leg_length, retarget_to

LOWER_BODY = ("LHipJoint", "RHipJoint")  # the joints whose subtrees are the legs (CCNet's 25-joint tree)
FACTOR = 0.8           # the paper's scale of subject 7's lower body
SEED_FRAMES = 120      # the paper's seed length (2 s at 60 fps)
SEAM_STEPS = 3         # frame-to-frame changes looked at from the seam on (50 ms)
REFERENCE_SECONDS = 1.0  # the seed's last second: its typical frame-to-frame change


def lower_body_joints(skeleton: Skeleton, roots=LOWER_BODY) -> list[int]:
    """Indices of ``roots`` and every joint below them (hip stubs, thighs, shins, feet, toes)."""
    top = {skeleton.index(n) for n in roots}
    return [j for j in range(skeleton.n_joints) if top & set(skeleton.chain(j))]


def scaled_lower_body(skeleton: Skeleton, factor: float = FACTOR, roots=LOWER_BODY) -> Skeleton:
    """``skeleton`` with the offsets (m) of the leg joints (:func:`lower_body_joints`: the hip
    joints' offsets from the root, thighs, shins, feet, toes) and their end sites times
    ``factor``; the root, spine, arms and head unchanged. Same joints, same rest directions."""
    legs = lower_body_joints(skeleton, roots)
    off = skeleton.offsets.copy()
    off[legs] *= factor
    ends = tuple((j, tuple(factor * np.asarray(o)) if j in legs else tuple(o)) for j, o in skeleton.end_sites)
    return Skeleton(skeleton.names, skeleton.parents, off, ends)


def retarget_seed(motion: Motion, body: Skeleton) -> Motion:
    """``motion`` (model joints) on ``body``: scaled about the origin to ``body``'s leg length
    first (root path and stride included: shorter legs take shorter steps, and a leg cannot
    reach ankles placed for a longer one), then :func:`mocapviz.tasks.rig.retarget_to` (local
    rotations kept, the hip joints' midpoint followed, two-bone leg IK onto the scaled ankles).
    For a body whose legs are the source's scaled by one factor the feet land exactly where the
    scaled source's do, on its floor times that factor (m, a few mm for a floor near 0)."""
    return retarget_to(motion.scaled(leg_length(body) / leg_length(motion.skeleton)), body)


def seed_rows(ds, subject: str | None = None, types=tf.LOCOMOTION_TYPES, n_seed: int = SEED_FRAMES) -> list[int]:
    """Clip rows of ``subject`` (default: the dataset's test subject) of locomotion ``types``
    with more than ``n_seed`` frame vectors (tr: its four jog clips)."""
    c = ds.clips
    subject = subject or ds.meta["test_subject"]
    ok = (c.subject == subject) & c.type.isin(types) & ((c.stop - c.start) > n_seed)
    return [int(i) for i in np.flatnonzero(ok.values)]


def body_dataset(ds, rows, factor: float = FACTOR):
    """A dataset of the clips ``rows`` of ``ds`` on their 7b bodies: each clip (``clip_motion``,
    the dataset's frames) retargeted (:func:`retarget_seed`) onto :func:`scaled_lower_body` of its
    skeleton, its frame vectors x (F-1, n_x), c^d (F-1, 12) and c^s recomputed. The clip table
    keeps names and types; its rows, start root and heading are the new features'. ``ds``'s
    normaliser, config and vocabulary, so every task that takes dataset rows runs on it."""
    xs, trajs, skels, offs, recs, at = [], [], [], [], [], 0
    for i in rows:
        body = scaled_lower_body(ds.skeleton(i), factor)
        f = motion_features(retarget_seed(ds.clip_motion(i), body), ds.config.fps)
        r = ds.clips.iloc[i].copy()
        r["start"], r["stop"], at = at, at + len(f.x), at + len(f.x)
        r["root_x"], r["root_y"], r["root_z"] = f.start_root
        r["heading"], r["height"] = f.start_heading, body.standing_height()
        xs.append(f.x), trajs.append(f.traj), skels.append(f.skel), offs.append(body.offsets), recs.append(r)
    clips = pd.DataFrame(recs).reset_index(drop=True).assign(body=f"{ds.meta['test_subject']} legs x{factor:g}")
    return replace(ds, x=np.concatenate(xs), traj=np.concatenate(trajs), skel=np.stack(skels),
                   offsets=np.stack(offs), clips=clips, meta={**ds.meta, "unseen_body_factor": factor})


def walk(model, normaliser, bds, rows, seconds: float = 10.0, n_seed: int = SEED_FRAMES,
         motion_type: str = "walk") -> Generated:
    """Every seed of ``rows`` of ``bds`` (its first ``n_seed`` frame vectors) continued for
    ``seconds`` of ``motion_type`` in one batch (mean output, the network's own c^d). c^t: the
    seed's own type on the seed frames, then blended into ``motion_type`` over 20 frames
    (:func:`~mocapviz.tasks.trajectory_following.blended_types`). The seed's c^d is fed where it
    does not look past the seed's end (:func:`~mocapviz.tasks.generate_bvh.seed_controls`: beyond,
    only an extrapolation exists). Returns the generated frame vectors, seed first."""
    n, n_types = int(round(seconds * bds.config.fps)), model.cfg.n_types
    arrs = [bds.clip_arrays(i) for i in rows]
    labels = [np.concatenate([np.repeat(one_hot([a["type_index"]], n_types), n_seed, 0),
                              tf.blended_types([motion_type] * n, MOTION_TYPES[a["type_index"]], n_types)])
              for a in arrs]
    return Generator(model, normaliser, batch=len(rows)).run(
        np.stack([a["x"][:n_seed] for a in arrs]), np.stack([a["skel"] for a in arrs]), np.stack(labels), n,
        seed_traj=np.stack([seed_controls(a["traj"][:n_seed]) for a in arrs]))


def generated_motion(gen: Generated, bds, rows, k: int) -> Motion:
    """Character ``k`` of ``gen`` (seed frames first) on its 7b skeleton, where its clip starts:
    the network's own poses, no foot IK (the IK would pin feet the network let slide)."""
    r = bds.clips.iloc[rows[k]]
    return gen.motion(k, bds.skeleton(rows[k]), (r.root_x, r.root_y, r.root_z), r.heading, ik=False,
                      name=r["clip"])


def walk_motions(model, normaliser, bds, rows, seconds: float = 10.0, n_seed: int = SEED_FRAMES) -> list[Motion]:
    """:func:`walk` as Motions (seed frames first; :func:`generated_motion`), one per row."""
    gen = walk(model, normaliser, bds, rows, seconds, n_seed)
    return [generated_motion(gen, bds, rows, k) for k in range(len(rows))]


def follow_motions(run: tf.Following, bds) -> list[Motion]:
    """The kept frames (``follow(..., keep=True)``) of a trajectory run as Motions, seed first."""
    return [generated_motion(run.generated, bds, run.rows, k) for k in range(len(run.rows))]


def command_motions(model, normaliser, meta: dict, bds, rows, seconds: float = 10.0,
                    n_seed: int = SEED_FRAMES) -> list[Motion]:
    """Walking as the ``generate`` command makes it
    (:func:`~mocapviz.tasks.generate_bvh.generate_from_seed`: the seed scaled into the training
    skeletons' root heights, c^s limited, the generated feet held to the seed's floor), from the
    first ``n_seed`` + 1 frames of each row (``n_seed`` frame vectors, as :func:`walk`'s); the
    first frame dropped, so that the seed is ``n_seed`` frames as in :func:`walk_motions`.
    ``meta``: the checkpoint's (its dataset's joints, fps and types)."""
    out = []
    for i in rows:
        seed = bds.clip_motion(i)[:n_seed + 1]
        g = generate_from_seed(seed, model, normaliser, meta, types=("walk",), seconds=seconds,
                               seed_seconds=(n_seed + 1) / bds.config.fps, ik=False)
        out.append(g.motion[1:])
    return out


def ground_frame(positions: np.ndarray, skeleton: Skeleton, height: bool = True) -> np.ndarray:
    """(F, J, 3) joint positions (m) relative to the root's point on the ground (X, Z of the
    root, height kept), in each frame's heading frame: a pose, plus how high the body is
    (``height=False``: relative to the root itself, the pose alone,
    :func:`mocapviz.metrics.local_positions`)."""
    positions = np.asarray(positions, dtype=np.float64)
    origin = positions[:, :1].copy()
    origin[..., 1] *= not height
    return to_heading_frame(positions - origin, heading_angles(positions, skeleton))


def seam_speeds(positions: np.ndarray, skeleton: Skeleton, n_seed: int, fps: float = FPS, steps: int = SEAM_STEPS,
                reference_seconds: float = REFERENCE_SECONDS, height: bool = True) -> tuple[float, float]:
    """(seam, reference) speeds in m/s of positions (F, J, 3) whose first ``n_seed`` frames are
    the seed: the fastest of the ``steps`` frame-to-frame changes from the last seed frame on
    (:func:`mocapviz.metrics.pose_speed` of :func:`ground_frame` positions: the mean over joints
    of |p_{n+1} - p_n| fps), and the median of the same over the seed's last ``reference_seconds``.
    ``height=False``: of the pose alone (root-relative), a jump of the body's height left out."""
    v = metrics.pose_speed(ground_frame(positions, skeleton, height), fps)    # v[n]: frame n -> n+1
    if n_seed < 3 or len(v) < n_seed - 1 + steps:
        raise ValueError(f"need at least 3 seed frames and {steps} after them, got {n_seed} of {len(positions)}")
    ref = v[max(0, n_seed - 1 - int(round(reference_seconds * fps))):n_seed - 1]
    return float(v[n_seed - 1:n_seed - 1 + steps].max()), float(np.median(ref))


def seam_jump(positions: np.ndarray, skeleton: Skeleton, n_seed: int, fps: float = FPS, steps: int = SEAM_STEPS,
              reference_seconds: float = REFERENCE_SECONDS, height: bool = True) -> float:
    """The seed-to-generation jump: :func:`seam_speeds`' seam speed over its reference speed.

    Why this: a "large, sharp change between the seed frames and generated frames" is a pose (or
    a body height) that changes in a frame or two by what the motion otherwise changes in many.
    The speed of the whole pose across the seam shows it in m/s; divided by the typical speed of
    the real motion just before (the seed's last second, the median: a gait cycle's fast and slow
    frames both count), it reads alike for a jog and a sneak. Positions relative to the root's
    ground point (:func:`ground_frame`): a body that drops or pops up at the seam counts, the
    ground speed (the root's travel) does not. The fastest of the first ``steps`` changes: a
    network that reaches its own pose over two or three frames is as sharp as one in a single
    frame. A real clip cut anywhere scores about 1 (the fastest of three frames against the
    median frame; measured on every cut of tr's clips of 100 frames or more: mean 1.2, per clip
    0.8-1.9, its jogs 1.2-1.5, 95 % of cuts under 3.4, where a throw or a kick starts from rest);
    10 means the body changed ten times as fast as it had been moving.
    A body that freezes at the seam scores 0: stopping is the freezing measures' business
    (:func:`mocapviz.metrics.freezing_share`), not this one's."""
    seam, ref = seam_speeds(positions, skeleton, n_seed, fps, steps, reference_seconds, height)
    return seam / max(ref, 1e-9)


def real_cut_jump(motion: Motion, first: int = 60, steps: int = SEAM_STEPS, height: bool = True) -> float:
    """Mean :func:`seam_jump` of a real ``motion`` cut at every frame from ``first`` (a second of
    reference before it) to the last with ``steps`` frames after it: what no jump scores."""
    p = motion.positions()
    return float(np.mean([seam_jump(p, motion.skeleton, s, motion.fps, steps, height=height)
                          for s in range(first, motion.n_frames - steps + 1)]))


def foot_ground(positions: np.ndarray, floor: float) -> dict[str, float]:
    """Where the lowest joint of each frame of positions (F, J, 3) is against the ``floor``
    height (m): ``penetration_cm``, its mean depth under the floor (0 above it;
    :func:`mocapviz.metrics.ground_penetration`), and ``foot_height_cm``, its median height above
    the floor (negative under it): feet through the floor (Fig. 9) or a body floating above it."""
    low = np.asarray(positions)[..., 1].min(axis=-1)
    return dict(penetration_cm=100.0 * metrics.ground_penetration(positions, floor),
                foot_height_cm=100.0 * float(np.median(low - floor)))


def measure(motions: list[Motion], n_seed: int) -> dict:
    """Means over generated motions (seed frames first) of :func:`seam_jump` (``jump``, with its
    max ``jump_max``, and ``jump_pose``: of the pose alone, without the body's height) and of
    :func:`foot_ground` of the generated frames against the seed's floor
    (:func:`mocapviz.tasks.rig.floor_height`), and ``penetration_1s_cm``: the depth over the first
    generated second (near the seam, before a drifting body has drifted). A mean of signed median
    heights lets a seed through the floor and one floating cancel: read it with the depths."""
    jumps, pose, ground = [], [], []
    for m in motions:
        p = m.positions()
        floor = floor_height(p[:n_seed])
        jumps.append(seam_jump(p, m.skeleton, n_seed, m.fps))
        pose.append(seam_jump(p, m.skeleton, n_seed, m.fps, height=False))
        first = foot_ground(p[n_seed:n_seed + int(round(m.fps))], floor)["penetration_cm"]
        ground.append(dict(foot_ground(p[n_seed:], floor), penetration_1s_cm=first))
    return dict(jump=float(np.mean(jumps)), jump_max=float(np.max(jumps)), jump_pose=float(np.mean(pose)),
                **{k: float(np.mean([g[k] for g in ground])) for k in ground[0]})


SHARP = 3.0       # a seam jump over this many times a real clip's is "sharp" (the paper's word)
FLOOR_CM = 5.0    # feet deeper than this under the floor on average are "through the floor"; a median
                  # lowest joint higher than this over it is "floating"


def seam_verdict(jump: float, real_jump: float) -> str:
    """"sharp" or "smooth": a :func:`seam_jump` against a real clip's cut anywhere."""
    return "sharp" if jump > SHARP * real_jump else "smooth"


def ground_verdict(penetration_cm: float, foot_height_cm: float) -> str:
    """"through the floor", "floating" or "on the floor", from :func:`foot_ground`'s two numbers."""
    if penetration_cm > FLOOR_CM:
        return "through the floor"
    return "floating" if foot_height_cm > FLOOR_CM else "on the floor"


def held_last(motion: Motion, n_after: int) -> Motion:
    """``motion`` with its last frame held ``n_after`` more frames: the do-nothing continuation."""
    idx = np.concatenate([np.arange(motion.n_frames), np.full(n_after, motion.n_frames - 1)])
    return replace(motion, rotations=motion.rotations[idx], root_positions=motion.root_positions[idx],
                   translations={j: t[idx] for j, t in motion.translations.items()})


# --- figures (matplotlib) ---------------------------------------------------------------------

SEAM_FRAMES = (-30, -15, -1, 0, 2, 5, 10, 20, 40)   # strip frames relative to the first generated one


def _side_view(ax, pose: np.ndarray, parents, x0: float, color: str, under_cm: float = 2.0) -> None:
    """One pose (J, 3) of :func:`ground_frame` positions, heights above the floor, drawn from the
    side (its forward on the page's x, placed at ``x0``); joints over ``under_cm`` under the floor
    in red (a real step's toe goes a centimetre or two under the median floor)."""
    from matplotlib.collections import LineCollection

    from mocapviz.viz.geometry import bone_segments
    xy = np.stack([pose[:, 2] + x0, pose[:, 1]], axis=-1)
    ax.add_collection(LineCollection(bone_segments(pose, parents)[..., [2, 1]] + [x0, 0.0], colors=color, lw=1.6))
    under = xy[:, 1] < -under_cm / 100.0
    ax.plot(xy[under, 0], xy[under, 1], "o", color="red", ms=3)


def seam_strip(motions: dict[str, Motion], n_seed: int, frames=SEAM_FRAMES, spacing: float = 0.8, path=None):
    """Film strips (one row per label) of a motion's seed end and generation start: the body
    from the side in its own heading (:func:`ground_frame`), at ``frames`` relative to the first
    generated frame (seed grey, generated coloured), heights above the seed's floor (the
    dashed line), joints over 2 cm under it red; each row titled with its :func:`seam_jump`. Returns the
    figure (:func:`mocapviz.viz.figures.save_figure` writes it to ``path``)."""
    import matplotlib.pyplot as plt

    from mocapviz.viz.figures import save_figure
    fig, axes = plt.subplots(len(motions), 1, figsize=(1.1 * spacing * len(frames) + 1.2, 2.3 * len(motions)),
                             squeeze=False)
    for ax, (label, m), color in zip(axes[:, 0], motions.items(), plt.cm.tab10.colors):
        p = m.positions()
        g = ground_frame(p, m.skeleton) - [0.0, floor_height(p[:n_seed]), 0.0]
        for k, f in enumerate(frames):
            _side_view(ax, g[n_seed + f], m.skeleton.parents, k * spacing, "0.6" if f < 0 else color)
            ax.text(k * spacing, -0.25, f"{f:+d}", ha="center", fontsize=7)
        ax.axhline(0.0, color="k", ls="--", lw=0.8)
        ax.axvline((frames.index(0) - 0.5) * spacing, color="k", lw=0.5)
        ax.set(xlim=(-0.5 * spacing, (len(frames) - 0.5) * spacing), ylim=(-0.3, 1.9), aspect="equal",
               yticks=[0, 0.5, 1, 1.5], title=f"{label}: jump {seam_jump(p, m.skeleton, n_seed, m.fps):.1f}",
               ylabel="m above floor")
        ax.set_xticks([])
    fig.tight_layout()
    save_figure(fig, path)
    return fig


def following_top_view(runs: dict, i: int = 0, title: str = "", path=None):
    """Top view of trajectory following: the target path (green) and each run's root path
    (``runs``: label -> :class:`~mocapviz.tasks.trajectory_following.Following`, one seed ``i``),
    its distance (cm) and coverage in the legend; the seed's end a black dot."""
    import matplotlib.pyplot as plt

    from mocapviz.viz.figures import save_figure
    fig, ax = plt.subplots(figsize=(6.5, 6))
    first = next(iter(runs.values()))
    ax.plot(*first.target[i].T, color="tab:green", lw=4, alpha=0.5, label="target")
    for label, r in runs.items():
        ax.plot(*r.achieved[i].T, lw=1.5, label=f"{label}: {r.distance_cm[i]:.0f} cm, covered {r.covered[i]:.2f}")
    ax.plot(*first.achieved[i][0], "ko", ms=5)
    ax.set(aspect="equal", xlabel="x (m)", ylabel="z (m)", title=f"{first.trajectory}{': ' if title else ''}{title}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
    return fig
