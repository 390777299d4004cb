"""The anny body model (naver/anny, Apache-2.0 code, CC0 MakeHuman assets) on its ``cmu_mb`` rig.

One wrapper, :class:`BodyModel`, that the rest of mocapviz talks to:

- float32 on CPU; the anny model is created once per process and rig (:func:`load_anny`);
  the first creation on a machine builds a ~0.8 GB cache in ``~/.cache/anny`` (about 1-3 min),
  announced by a log line, never silently.
- body shape ``beta`` = anny's six phenotype parameters, in this order (:data:`BETA_LABELS`):
  gender (0 male .. 1 female), age (anny's age axis: 0.67 ~ 16 y, 0.77 ~ 18 y, 0.83 ~ 64 y,
  1.0 ~ 110 y), muscle, weight, height, proportions (0 ideal .. 1 uncommon), each in [0, 1].
  The paper conditions on SMPL's 8 betas; anny's phenotypes are the closest interpretable
  equivalent (6 numbers, bounded, with a published population distribution).
- joints are anny's ``cmu_mb`` bones, renamed to the CMU BVH names (anny calls the index
  finger ``LeftHandFinger1``, CMU ``LeftHandIndex1``), in anny's order (:attr:`joint_names`).
- pose convention is mocapviz's: local rotations (B, J, 3, 3) with global = parent_global @
  local, identity = anny's rest pose (an A-pose), and the root translation = the Hips bone
  head, in metres with Y up. anny is Z up; the axis change is folded into the root transform,
  so meshes come out of anny already in Y up (no per-vertex conversion).

Why this works: with ``pose_parameterization="local-ref"`` and the root's rest orientation
forced to identity (the cmu_mb default), anny's forward kinematics is exactly
``G_c = G_p D_c`` (G = rotation of a bone relative to its rest orientation, in world axes)
and the root bone's head lands at the root delta's translation. Left-multiplying the root
delta by the Z-up -> Y-up change of basis C therefore maps every posed vertex by C.
"""

from __future__ import annotations

import functools
import logging
import sys
import time
from dataclasses import dataclass

import numpy as np
import torch

from mocapviz.skeleton import Skeleton

log = logging.getLogger(__name__)

BETA_LABELS = ("gender", "age", "muscle", "weight", "height", "proportions")
# Bounds used by shape fitting: an adult age window (anny's age axis via its own
# morphological-age calibration: 0.70 ~ 16.6 y, 0.85 ~ 70 y); the others span anny's range.
BETA_BOUNDS = {"gender": (0.0, 1.0), "age": (0.70, 0.85), "muscle": (0.0, 1.0),
               "weight": (0.0, 1.0), "height": (0.0, 1.0), "proportions": (0.0, 1.0)}
# The starting shape of every fit: an average adult (age 0.8 ~ 41 y on anny's age axis).
NEUTRAL_BETA = np.array([0.5, 0.8, 0.5, 0.5, 0.5, 0.5], dtype=np.float32)

ANNY_TO_CMU_NAMES = {"LeftHandFinger1": "LeftHandIndex1", "RightHandFinger1": "RightHandIndex1"}

# Z up (anny) -> Y up (mocapviz): (x, y, z) -> (x, z, -y). Anny faces -Y, so we face +Z.
Z_TO_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def _anny_cache_logging():
    """Show anny's own cache messages (build / load) on stderr while a model is created."""
    logger = logging.getLogger("anny.models.model_data")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("[anny] %(message)s"))
    return logger, handler


@functools.lru_cache(maxsize=None)
def load_anny(rig: str = "cmu_mb", skinning: str = "warp_lbs"):
    """The anny model for ``rig`` in float32 on CPU, created once per process.

    The first creation on a machine builds anny's cache (about 0.8 GB in ~/.cache/anny,
    1-3 minutes on 2 cores); we say so before it starts, and anny's own cache log lines are
    shown while it runs.
    """
    import anny
    from anny.paths import get_anny_cache_path

    cache = get_anny_cache_path()
    first = not any(cache.glob("v*/build_compact_model_data_*.safetensors")) if cache.exists() else True
    if first:
        print(f"[mocapviz] building the anny '{rig}' model cache in {cache} (once per machine, "
              "~0.8 GB, 1-3 minutes)...", file=sys.stderr, flush=True)
    logger, handler = _anny_cache_logging()
    old_level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    t0 = time.perf_counter()
    try:
        model = anny.Anny(rig=rig, pose_parameterization="local-ref", skinning_method=skinning)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
    model = model.to(dtype=torch.float32).eval()
    for p in model.parameters():
        p.requires_grad_(False)
    dt = time.perf_counter() - t0
    if first or dt > 10:
        print(f"[mocapviz] anny '{rig}' model ready in {dt:.0f} s", file=sys.stderr, flush=True)
    return model


@dataclass
class BodyMesh:
    """Output of :meth:`BodyModel.mesh`: vertices (B, V, 3) and joints (B, J, 3), metres, Y up."""

    vertices: torch.Tensor
    joints: torch.Tensor


class BodyModel:
    """anny's cmu_mb body, in mocapviz conventions (see the module docstring)."""

    def __init__(self, rig: str = "cmu_mb", skinning: str = "warp_lbs", n_subset: int = 1024):
        self.anny = load_anny(rig, skinning)
        self.rig = rig
        self.joint_names = tuple(ANNY_TO_CMU_NAMES.get(n, n) for n in self.anny.bone_labels)
        self.parents = np.array(self.anny.bone_parents, dtype=np.int64)
        self.faces = self.anny.faces.cpu().numpy()
        self.n_vertices = int(self.anny.template_vertices.shape[0])
        self._C = torch.tensor(Z_TO_Y, dtype=torch.float32)
        self._n_subset = n_subset
        self._subset = None

    # ------------------------------------------------------------------ shape
    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def index(self, name: str) -> int:
        return self.joint_names.index(name)

    def beta_tensor(self, beta) -> torch.Tensor:
        """``beta`` (6,) or (B, 6), array or tensor, as a float32 tensor (B, 6); checks the size."""
        beta = torch.as_tensor(np.asarray(beta, dtype=np.float32) if not torch.is_tensor(beta) else beta,
                               dtype=torch.float32)
        if beta.ndim == 1:
            beta = beta[None]
        if beta.shape[-1] != len(BETA_LABELS):
            raise ValueError(f"beta must have {len(BETA_LABELS)} values {BETA_LABELS}, got {tuple(beta.shape)}")
        return beta

    def blendshape_coefficients(self, beta) -> torch.Tensor:
        """anny's blendshape coefficients (B, K) for phenotypes ``beta`` (B, 6); differentiable."""
        beta = self.beta_tensor(beta)
        empty = beta.new_zeros((beta.shape[0], 0))
        labels = list(self.anny.phenotype_labels)
        order = [BETA_LABELS.index(k) for k in labels]
        return self.anny._get_phenotype_blendshape_coefficients(beta[:, order], empty, empty)

    def rest_joints(self, beta) -> torch.Tensor:
        """Rest (A-pose) joint positions (B, J, 3), Y up, the Hips head at its rest place;
        differentiable in beta (used by shape fitting)."""
        from anny.skinning.skinning import apply_linear_blendshape

        coeffs = self.blendshape_coefficients(beta)
        heads = apply_linear_blendshape(self.anny.template_bone_heads, self.anny.bone_heads_blendshapes, coeffs)
        return heads @ self._C.T

    def rest_model(self, beta) -> dict:
        """Rest vertices, joint heads and bone tails (B, ., 3) in metres, Y up."""
        with torch.no_grad():
            out = self.anny.get_rest_model(self.blendshape_coefficients(beta))
        res = {"vertices": out["rest_vertices"] @ self._C.T, "joints": out["rest_bone_heads"] @ self._C.T}
        if "rest_bone_tails" in out:
            res["tails"] = out["rest_bone_tails"] @ self._C.T
        return res

    def rest_skeleton(self, beta) -> Skeleton:
        """The rest (A-pose) skeleton of body ``beta`` as a mocapviz Skeleton (CMU names).

        Offsets are joint-head differences (the root's offset is 0: a Motion's root position
        is the Hips head); each leaf gets its bone tail as an end site. FK of this skeleton
        equals the joints of :meth:`mesh` for the same rotations and root positions.
        """
        rest = self.rest_model(beta)
        heads = rest["joints"][0].double().numpy()
        tails = rest["tails"][0].double().numpy()
        offsets = np.zeros_like(heads)
        offsets[1:] = heads[1:] - heads[self.parents[1:]]
        ends = tuple((j, tuple(float(v) for v in tails[j] - heads[j])) for j in range(self.n_joints)
                     if not np.any(self.parents == j))
        return Skeleton(self.joint_names, self.parents, offsets, ends)

    def measurements(self, beta) -> dict:
        """Height (m), mass (kg), BMI and waist (m) of the rest mesh, by anny's Anthropometry."""
        from anny.anthropometry import Anthropometry

        anthro = Anthropometry(self.anny)
        with torch.no_grad():
            verts = self.anny.get_rest_vertices(self.blendshape_coefficients(beta))
            out = anthro(verts)
        return {k: v.numpy() for k, v in out.items()}

    # ------------------------------------------------------------------ pose
    def pose_parameters(self, rotations, root_positions) -> torch.Tensor:
        """anny pose deltas (B, J, 4, 4) for mocapviz local rotations and Hips positions (Y up).

        Non-root bones get C^T R C (the local rotation in anny's Z-up axes); the root gets
        [R_root C | root], which maps anny's whole posed body from Z up into Y up.
        """
        rot = torch.as_tensor(rotations, dtype=torch.float32)
        root = torch.as_tensor(root_positions, dtype=torch.float32)
        if rot.ndim == 3:
            rot, root = rot[None], root[None]
        if rot.shape[-3] != self.n_joints:
            raise ValueError(f"rotations must have {self.n_joints} joints in BodyModel.joint_names order")
        C = self._C
        pose = torch.zeros(rot.shape[:-2] + (4, 4), dtype=torch.float32)
        pose[..., 3, 3] = 1.0
        pose[..., 1:, :3, :3] = C.T @ rot[..., 1:, :, :] @ C
        pose[..., 0, :3, :3] = rot[..., 0, :, :] @ C
        pose[..., 0, :3, 3] = root
        return pose

    def rotations_from_pose_parameters(self, pose: torch.Tensor) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`pose_parameters`: (rotations (B, J, 3, 3), root (B, 3)) as numpy."""
        C = self._C.double()
        pose = pose.double()
        rot = torch.empty(pose.shape[:-2] + (3, 3), dtype=torch.float64)
        rot[..., 1:, :, :] = C @ pose[..., 1:, :3, :3] @ C.T
        rot[..., 0, :, :] = pose[..., 0, :3, :3] @ C.T
        return rot.numpy(), pose[..., 0, :3, 3].numpy()

    def mesh(self, beta, rotations, root_positions, joints: bool = False) -> BodyMesh:
        """Mesh a whole sequence in one batch: beta (6,) or (B, 6), rotations (F, J, 3, 3),
        root (F, 3). Returns vertices (F, V, 3) (and posed joint heads) in metres, Y up."""
        pose = self.pose_parameters(rotations, root_positions)
        with torch.no_grad():
            out = self.anny(pose, phenotype_kwargs=self.beta_tensor(beta)[:, self._anny_order])
        bone_poses = out["bone_poses"]
        return BodyMesh(out["vertices"], bone_poses[..., :3, 3] if joints else None)

    def mesh_cycles(self, betas, rotations, root_positions) -> torch.Tensor:
        """Mesh several sequences in one batch: betas (B, 6), rotations (B, F, J, 3, 3),
        roots (B, F, 3) -> vertices (B, F, V, 3). Each body's rest shape is computed once;
        posing and skinning run on all B x F frames together."""
        betas = self.beta_tensor(betas)
        rot = torch.as_tensor(rotations, dtype=torch.float32)
        root = torch.as_tensor(root_positions, dtype=torch.float32)
        n_b, n_f = rot.shape[:2]
        if betas.shape[0] != n_b:
            raise ValueError(f"{betas.shape[0]} betas for {n_b} sequences")
        pose = self.pose_parameters(rot.reshape((n_b * n_f,) + rot.shape[2:]), root.reshape(n_b * n_f, 3))
        with torch.no_grad():
            rest = self.anny.get_rest_model(self.blendshape_coefficients(betas))
            transforms, _ = self.anny.get_bone_transforms(pose, rest["rest_bone_poses"].repeat_interleave(n_f, 0))
            verts = self.anny.get_skinned_vertices(rest["rest_vertices"].repeat_interleave(n_f, 0), transforms)
        return verts.reshape(n_b, n_f, -1, 3)

    @functools.cached_property
    def _anny_order(self) -> list[int]:
        return [BETA_LABELS.index(k) for k in self.anny.phenotype_labels]

    # ------------------------------------------------------------------ subsets
    def vertex_subset(self) -> np.ndarray:
        """A fixed, decimated vertex subset (``n_subset`` indices) for fast losses.

        Farthest-point sampling on the neutral rest mesh, starting from vertex 0: the same
        indices on every run and machine (pure arithmetic, no randomness).
        """
        if self._subset is None:
            verts = self.rest_model(NEUTRAL_BETA)["vertices"][0].numpy()
            self._subset = farthest_point_sampling(verts, self._n_subset)
        return self._subset


def farthest_point_sampling(points, n: int) -> np.ndarray:
    """Indices of ``n`` points chosen greedily, each the farthest from those already chosen."""
    points = np.asarray(points, dtype=np.float32)
    n = min(n, points.shape[0])
    chosen = np.zeros(n, dtype=np.int64)
    dist = np.full(points.shape[0], np.inf, dtype=np.float32)
    idx = 0
    for i in range(n):
        chosen[i] = idx
        diff = points - points[idx]
        dist = np.minimum(dist, np.einsum("ij,ij->i", diff, diff))
        idx = int(np.argmax(dist))
    return chosen


@functools.lru_cache(maxsize=None)
def body_model(rig: str = "cmu_mb") -> BodyModel:
    """The shared BodyModel of a rig (one per process)."""
    return BodyModel(rig)
