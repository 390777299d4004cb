"""Which z keeps a user's posture: a search around the seed's own z by short rollouts.

A latent CCNet (``ccnet_generate``) reads z from the seed (``Generator(z_source="seed")``), but
run free it settles into its motion type's usual posture within a second: every HDM05
``jogLeftCircle`` seed, leaning 7-21 degrees, jogged at 8-9 degrees with the type's z, and the
seed's own z moved that by -6 to +3 (docs/experiments.md, "Why a generated sneak stands up").
Teacher-forced, z and the input frames say the same thing, so the network never learnt to hold a
posture from z alone; posture controls trained for it were weak (runs P1-P3). Some codes near the
seed's do hold it, and rollouts are cheap (two rounds of 32 characters for 8 s take about 5 s on
one CPU thread), so the generator looks for one.

:func:`search_seed_z`: ``candidates`` codes, the seed's z plus shifts drawn from the motion
type's prior spread (its Cholesky factor) times a ``spread`` (the first candidate is the seed's z
itself), are run in one batch for ``seconds`` with the mean output and the output's foot IK;
the second half of each rollout is measured (:class:`Posture`) on the user's body against the
seed frames; a second round draws around the best at a smaller spread, and the code whose
:func:`posture_cost` is lowest is the one generated with. The generated seconds a user keeps
(and the benchmark measures, seconds 30-60 of ``benchmarks/bench_generate_files.py``) lie after
the probe's, so a code that only happens to start right is not enough.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from tqdm.auto import tqdm

from mocapviz import metrics
from mocapviz.features.ccnet import FPS
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton

# how far a rollout may be from the seed before its cost reaches 1 per measure: the root
# height within 5 % (the standing height a person sees first), the lean within 5 degrees,
# pace and activity within a factor of 2 (the bars of benchmarks/bench_generate_files.py for
# height, pace and activity; a standing seed's pace of 0 counts from SPEED_FLOOR so the ratio
# stays defined). Why 5 degrees, not 10: with 10 the tr jog on the Mixamo A-pose skeleton
# traded lean for height and leaned 18.4 degrees, the seed 16.3 (real jogs 4.8-17.8)
HEIGHT_TOLERANCE = np.log(1.05)
LEAN_TOLERANCE = 5.0  # degrees
RATE_TOLERANCE = np.log(2.0)
SPEED_FLOOR = 0.1      # m/s
ACTIVITY_FLOOR = 0.05  # m/s
MIN_SEED_SECONDS = 0.5  # a shorter seed shows too little of its pace and posture to match


@dataclass(frozen=True)
class Posture:
    """How a body moves over a stretch of frames (Y up, metres)."""
    height: float    # mean root height above the floor (the median of the lowest joint), m
    lean: float      # mean forward lean of hips -> neck from the rest pose's (metrics.forward_lean), degrees
    speed: float     # mean ground speed of the root, m/s
    activity: float  # mean joint speed in the root's heading frame (metrics.activity), m/s


def posture_of(motion: Motion, floor: float | None = None) -> Posture:
    """The :class:`Posture` of every frame of ``motion`` (model joints: hips, neck and shoulders
    named); the root height above ``floor`` (m; default: the motion's own, the median over its
    frames of the lowest joint)."""
    pos = motion.positions()
    if floor is None:
        floor = float(np.median(pos[:, :, 1].min(axis=1)))
    return Posture(height=float((motion.root_positions[:, 1] - floor).mean()),
                   lean=float(metrics.forward_lean(pos, motion.skeleton).mean()),
                   speed=metrics.root_speed(motion.root_positions, motion.fps),
                   activity=metrics.activity(metrics.local_positions(pos, motion.skeleton), motion.fps))


def posture_cost(p: Posture, target: Posture) -> float:
    """Sum over the four measures of (deviation of ``p`` from ``target`` / its tolerance)^2:
    log ratios for height, pace and activity, degrees for the lean."""
    terms = (np.log(p.height / target.height) / HEIGHT_TOLERANCE,
             (p.lean - target.lean) / LEAN_TOLERANCE,
             np.log((p.speed + SPEED_FLOOR) / (target.speed + SPEED_FLOOR)) / RATE_TOLERANCE,
             np.log((p.activity + ACTIVITY_FLOOR) / (target.activity + ACTIVITY_FLOOR)) / RATE_TOLERANCE)
    return float(sum(t * t for t in terms))


@dataclass
class ZSearch:
    shift: np.ndarray         # (L,) what the chosen code adds to the seed's z
    chosen: int               # its index among the candidates of every round (0: the seed's z itself)
    costs: np.ndarray         # (rounds x K,) posture_cost of every candidate, round by round
    postures: list[Posture]   # every candidate's, over the second half of its rollout
    target: Posture           # the seed's

    def summary(self) -> str:
        """One line on what the search did (the ``generate`` command prints it)."""
        p, t = self.postures[self.chosen], self.target
        kept = "the seed's own z" if self.chosen == 0 else f"code {self.chosen}"
        return (f"z searched over {len(self.costs)} codes: kept {kept} (cost {self.costs[0]:.2f} with the seed's z, "
                f"{self.costs[self.chosen]:.2f} kept); in its trial run, root height {p.height / t.height:.3f}x the "
                f"seed's, lean {p.lean:+.1f} degrees (seed {t.lean:+.1f}), pace {p.speed:.2f} m/s (seed {t.speed:.2f})")


def candidate_shifts(type_prior, type_index: int, candidates: int, spread: float, rng_seed: int) -> np.ndarray:
    """(K, L) shifts of the seed's z: 0 first, then draws from N(0, (spread C)(spread C)^T),
    C the type's Cholesky factor (seeded: the same request gets the same candidates)."""
    chol = type_prior.chol[type_index]
    e = np.random.default_rng(rng_seed).standard_normal((candidates, chol.shape[0])).astype(np.float32)
    e[0] = 0.0
    return (spread * e @ chol.T).astype(np.float32)


def search_seed_z(model, normaliser, seed_x: np.ndarray, skel: np.ndarray, types: np.ndarray,
                  seed_traj: np.ndarray, skeleton: Skeleton, target: Posture, candidates: int,
                  seconds: float, spreads: tuple[float, ...], pace: str, rng_seed: int = 0, ik: bool = True,
                  to_target_body: Callable[[Motion], Motion] | None = None, progress: bool = False) -> ZSearch | None:
    """The code near the seed's z whose rollout keeps ``target`` best (module docstring), or None
    where there is nothing to search (a model without a latent or a type prior, fewer than 2
    candidates). One round per entry of ``spreads``, each of ``candidates`` codes around the
    best so far (the first round's around the seed's z) at that multiple of the type's spread;
    each round's candidate 0 is the best so far, so the cost never rises from round to round.
    ``seed_x`` (S, n_x) raw seed frame vectors, ``skel`` (n_skel,) the c^s the network sees,
    ``types`` (n_types,) the one-hot motion type, ``seed_traj`` (S, 12) the seed's c^d (NaN
    rows: the network's own), ``skeleton`` the model skeleton they are on; ``ik``: the rollouts
    get the foot IK the output gets; ``to_target_body`` takes a rollout (on ``skeleton``) to the
    body ``target`` was measured on. Why measure there: retargeted from a Mixamo A-pose body
    onto the training body, the tr jog seed's lean reads 20.4 degrees instead of 16.3, its
    generated frames' 11.0 instead of 10.0."""
    prior = getattr(model, "type_prior", None)
    if not model.cfg.latent or prior is None or candidates < 2 or not spreads:
        return None
    type_index = int(np.argmax(types))
    best = np.zeros(model.cfg.latent, np.float32)
    all_shifts, postures = [], []
    for r, spread in enumerate(tqdm(spreads, desc=f"z search ({candidates} codes a round)", disable=not progress)):
        shifts = best + candidate_shifts(prior, type_index, candidates, spread, rng_seed + r)
        postures += _rollout_postures(model, normaliser, seed_x, skel, types, seed_traj, skeleton, shifts, seconds,
                                      pace, ik, to_target_body)
        all_shifts.append(shifts)
        costs = np.array([posture_cost(p, target) for p in postures])
        best = np.concatenate(all_shifts)[int(np.argmin(costs))]
    chosen = int(np.argmin(costs))
    return ZSearch(np.concatenate(all_shifts)[chosen], chosen, costs, postures, target)


def _rollout_postures(model, normaliser, seed_x, skel, types, seed_traj, skeleton, shifts, seconds, pace, ik,
                      to_target_body) -> list[Posture]:
    """The :class:`Posture` of the second half of a ``seconds`` rollout (mean output) of each code shift."""
    from mocapviz.tasks.generate import Generator  # torch: only when searching

    k = len(shifts)
    rep = lambda a: np.repeat(np.asarray(a, np.float32)[None], k, axis=0)  # noqa: E731
    gen = Generator(model, normaliser, batch=k, pace=pace, z_source="seed", z_shift=shifts).run(
        rep(seed_x), rep(skel), rep(types), int(round(seconds * FPS)), seed_traj=rep(seed_traj))
    out = []
    for i in range(k):
        m = gen.motion(i, skeleton, include_seed=False, ik=ik)
        m = m if to_target_body is None else to_target_body(m)
        out.append(posture_of(m[m.n_frames // 2:]))
    return out
