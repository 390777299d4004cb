"""Fit anny's body shape (beta = phenotypes) to a mocap subject's skeleton.

The loss compares *segment lengths*: distances between corresponding joint centres of the
subject's rest skeleton and of anny's cmu_mb rest skeleton. We use the segments whose end
points mean the same anatomical joint in CMU BVH, HDM05 ASF and anny (hip, knee, ankle,
ball of foot, shoulder, elbow, wrist), plus hip width, shoulder width and trunk height
(hip-centre to shoulder-centre). Joints that differ by definition between the rigs (CMU's
zero-length Neck and clavicle roots, anny's Hips placed at hip height) are left out: their
"bone lengths" are conventions, not body measurements.

Optimisation: Adam on an unconstrained parameter mapped by a sigmoid into the bounds of
:data:`~mocapviz.bodies.anny_model.BETA_BOUNDS`, all subjects in one batch, plus a weak
quadratic pull towards the neutral adult for the phenotypes that bone lengths hardly see
(muscle and weight change girth, not length).

The shape prior (what bone lengths cannot tell). Gender is not identifiable from segment
lengths: fitted freely it ran to a bound (every body female, although the five HDM05 actors are
men). So gender is never fitted: a subject's recorded gender is passed in ``fixed`` (0 = male,
1 = female; see ``data_prep.body4d_dataset.SUBJECT_GENDER``), and an unrecorded one stays at
anny's midpoint 0.5 (neither look, said as such). Age is barely identifiable either (anny's
adult age changes proportions by millimetres) and ran to a bound of its adult window; a
quadratic pull (:data:`PRIOR_WEIGHTS`) towards the neutral adult's 0.8 (~41 y) keeps it where
the bone lengths do not argue for another value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import torch

from mocapviz.bodies.anny_model import BETA_BOUNDS, BETA_LABELS, NEUTRAL_BETA, BodyModel
from mocapviz.skeleton import Skeleton

# name -> (point A, point B); a point is a tuple of joint names whose mean is taken.
SEGMENTS = {
    "thigh.L": (("LeftUpLeg",), ("LeftLeg",)),
    "shin.L": (("LeftLeg",), ("LeftFoot",)),
    "foot.L": (("LeftFoot",), ("LeftToeBase",)),
    "thigh.R": (("RightUpLeg",), ("RightLeg",)),
    "shin.R": (("RightLeg",), ("RightFoot",)),
    "foot.R": (("RightFoot",), ("RightToeBase",)),
    "upper_arm.L": (("LeftArm",), ("LeftForeArm",)),
    "forearm.L": (("LeftForeArm",), ("LeftHand",)),
    "upper_arm.R": (("RightArm",), ("RightForeArm",)),
    "forearm.R": (("RightForeArm",), ("RightHand",)),
    "hip_width": (("LeftUpLeg",), ("RightUpLeg",)),
    "shoulder_width": (("LeftArm",), ("RightArm",)),
    "trunk": (("LeftUpLeg", "RightUpLeg"), ("LeftArm", "RightArm")),
}
PRIOR_WEIGHTS = {"gender": 0.0, "age": 3e-2, "muscle": 1e-4, "weight": 1e-4, "height": 0.0,
                 "proportions": 1e-4}


def _segment_matrix(names) -> tuple[np.ndarray, np.ndarray]:
    """Matrices A, B (S, J) with A @ positions = point A of each segment (means of joints)."""
    a = np.zeros((len(SEGMENTS), len(names)))
    b = np.zeros_like(a)
    for s, (pa, pb) in enumerate(SEGMENTS.values()):
        for n in pa:
            a[s, names.index(n)] = 1.0 / len(pa)
        for n in pb:
            b[s, names.index(n)] = 1.0 / len(pb)
    return a, b


def segment_lengths(skeleton: Skeleton) -> np.ndarray:
    """Lengths (S,) in metres of :data:`SEGMENTS` in the skeleton's rest pose."""
    a, b = _segment_matrix(list(skeleton.names))
    rest = skeleton.rest_positions()
    return np.linalg.norm(a @ rest - b @ rest, axis=-1)


def _anny_segment_lengths(body: BodyModel, beta: torch.Tensor) -> torch.Tensor:
    a, b = _segment_matrix(list(body.joint_names))
    joints = body.rest_joints(beta)
    a = torch.as_tensor(a, dtype=joints.dtype)
    b = torch.as_tensor(b, dtype=joints.dtype)
    return torch.linalg.norm(a @ joints - b @ joints, dim=-1)


def anny_segment_lengths(body: BodyModel, beta) -> np.ndarray:
    with torch.no_grad():
        return _anny_segment_lengths(body, body.beta_tensor(beta)).numpy()


@dataclass
class ShapeFit:
    """Fitted betas (N, 6) and per-segment errors (N, S) in metres before and after."""

    subjects: list
    beta: np.ndarray
    target: np.ndarray
    before: np.ndarray
    after: np.ndarray

    def report(self) -> pd.DataFrame:
        """Per subject: mean absolute segment-length error (cm) before and after, and beta."""
        df = pd.DataFrame({
            "subject": self.subjects,
            "err_before_cm": 100 * np.abs(self.before).mean(1),
            "err_after_cm": 100 * np.abs(self.after).mean(1),
            "max_after_cm": 100 * np.abs(self.after).max(1),
        })
        for i, k in enumerate(BETA_LABELS):
            df[k] = self.beta[:, i]
        return df


def fit_shapes(body: BodyModel, skeletons: dict, steps: int = 100, lr: float = 0.1,
               init=NEUTRAL_BETA, fixed: dict | None = None) -> ShapeFit:
    """Fit one beta per subject (``skeletons``: subject -> Skeleton), all in one batch.

    Gradient-based (Adam) on the mean squared segment-length error in metres, with betas
    kept inside BETA_BOUNDS by a sigmoid. Starts from ``init`` (the neutral adult), which
    is also what the "before" error measures. ``fixed`` (subject -> {label: value}) holds
    phenotypes that are known, not fitted; gender is never fitted (module docstring): a
    subject without a recorded gender keeps ``init``'s (0.5).
    """
    subjects = list(skeletons)
    fixed = fixed or {}
    target = torch.tensor(np.stack([segment_lengths(skeletons[s]) for s in subjects]), dtype=torch.float32)
    lo = torch.tensor([BETA_BOUNDS[k][0] for k in BETA_LABELS], dtype=torch.float32)
    hi = torch.tensor([BETA_BOUNDS[k][1] for k in BETA_LABELS], dtype=torch.float32)
    init = torch.as_tensor(np.asarray(init, dtype=np.float32)).expand(len(subjects), -1).clone()
    init = torch.minimum(torch.maximum(init, lo + 1e-3), hi - 1e-3)
    # phenotypes held at a value (``keep``): gender always, anything ``fixed`` names
    keep = torch.zeros(init.shape, dtype=torch.bool)
    keep[:, BETA_LABELS.index("gender")] = True
    value = init.clone()
    for i, s in enumerate(subjects):
        for k, v in fixed.get(s, {}).items():
            keep[i, BETA_LABELS.index(k)] = True
            value[i, BETA_LABELS.index(k)] = float(v)
    prior = torch.tensor([PRIOR_WEIGHTS[k] for k in BETA_LABELS], dtype=torch.float32)
    x = torch.logit((init - lo) / (hi - lo)).requires_grad_(True)
    opt = torch.optim.Adam([x], lr=lr)

    def beta_of(x):
        return torch.where(keep, value, lo + (hi - lo) * torch.sigmoid(x))

    with torch.no_grad():
        before = (_anny_segment_lengths(body, init) - target).numpy()
    for _ in range(steps):
        opt.zero_grad()
        beta = beta_of(x)
        err = _anny_segment_lengths(body, beta) - target
        loss = (err ** 2).mean(1).sum() + ((beta - init) ** 2 * prior).sum()
        loss.backward()
        opt.step()
    with torch.no_grad():
        beta = beta_of(x)
        after = (_anny_segment_lengths(body, beta) - target).numpy()
    return ShapeFit(subjects, beta.numpy(), target.numpy(), before, after)
