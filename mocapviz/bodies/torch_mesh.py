"""A differentiable path chi -> mesh in torch (multi-frame 4D motion paper §3.3, phase 2).

:class:`ChiMesher` maps motions chi (B, N, 6K+4) (:mod:`mocapviz.bodies.representation`) and
body shapes beta (B, 6) to vertices (B, N, V, 3) in metres, Y up, with gradients all the way:

1. Theta + identity -> local rotations by Gram-Schmidt (``roma.special_gramschmidt``); the
   dropped joints keep the identity (anny's rest relation), as in ``representation.decode``;
2. Gamma x ``gamma_scale`` (+ ``root0``) -> the Hips head positions;
3. anny's rest shape of beta: rest vertices and bone heads by anny's linear blendshapes, Y up;
4. forward kinematics in mocapviz's convention: global = parent_global @ local, a joint's head
   = its parent's head + parent_global @ (rest offset); bone transform A_j = [G_j | h_j - G_j r_j];
5. linear blend skinning with anny's weights, v' = sum_j w_vj A_j [v; 1], written as one batched
   matmul of a per-body (V, 4J) matrix [w_vj v, w_vj] with the (4J, 3) stacked transforms.

Why not anny's own forward: its skinning kernel (warp) is float32 only, so it cannot be checked
by ``torch.autograd.gradcheck`` in float64; the matmul form is one BLAS call per body on CPU and
its backward is another. anny's local-ref FK is exactly step 4 (see :mod:`.anny_model`), and a
test checks this path against :meth:`BodyModel.mesh` (anny's own path) on real cycles.

``vertices``: an optional fixed subset (indices into anny's vertices, e.g.
:meth:`BodyModel.vertex_subset`) for cheaper losses; skinning cost is linear in its size.
"""

from __future__ import annotations

import numpy as np
import roma
import torch

from mocapviz.bodies.anny_model import BodyModel
from mocapviz.bodies.representation import IDENTITY_6D, PHI_SCALE, chi_joint_indices


def skinning_weights(body: BodyModel) -> torch.Tensor:
    """anny's skinning weights as a dense (V, J) float64 matrix (rows sum to 1)."""
    w = torch.zeros(body.n_vertices, body.n_joints, dtype=torch.float64)
    w.scatter_add_(1, body.anny.vertex_bone_indices.long(), body.anny.vertex_bone_weights.double())
    return w


class ChiMesher(torch.nn.Module):
    """chi (B, N, 6K+4), beta (B, 6) -> vertices (B, N, V', 3), metres, Y up (module docstring)."""

    def __init__(self, body: BodyModel, gamma_scale, vertices=None, dtype=torch.float32):
        super().__init__()
        self.body = body
        self.dtype = dtype
        kept = chi_joint_indices(body.joint_names)
        self.kept = [int(k) for k in kept]
        self.n_joints = body.n_joints
        self.parents = [int(p) for p in body.parents]
        idx = torch.arange(body.n_vertices) if vertices is None else torch.as_tensor(np.asarray(vertices)).long()
        w = skinning_weights(body)[idx]
        self.bones = [j for j in range(self.n_joints) if bool((w[:, j] > 0).any())]  # bones that skin a vertex
        self.register_buffer("vertex_index", idx)
        self.register_buffer("weights", w[:, self.bones].to(dtype))
        self.register_buffer("gamma_scale", torch.as_tensor(np.asarray(gamma_scale, dtype=np.float64)).to(dtype))
        self.register_buffer("identity_6d", torch.as_tensor(IDENTITY_6D).to(dtype))

    @property
    def n_vertices(self) -> int:
        return int(self.vertex_index.shape[0])

    # ------------------------------------------------------------------ pieces
    def rest_shape(self, beta) -> tuple[torch.Tensor, torch.Tensor]:
        """Rest vertices (B, V', 3) and bone heads (B, J, 3) of bodies beta (B, 6), Y up;
        differentiable in beta (anny's blendshapes run in anny's float32)."""
        from anny.skinning.skinning import apply_linear_blendshape

        anny = self.body.anny
        coeffs = self.body.blendshape_coefficients(beta)
        verts = apply_linear_blendshape(anny.template_vertices[self.vertex_index],
                                        anny.blendshapes[:, self.vertex_index], coeffs)
        C = self.body._C
        return (verts @ C.T).to(self.dtype), self.body.rest_joints(beta).to(self.dtype)

    def local_rotations(self, chi: torch.Tensor) -> torch.Tensor:
        """Local rotations (B, N, J, 3, 3) of chi (B, N, 6K+4); dropped joints are the identity."""
        n_k = len(self.kept)
        six = chi[..., :6 * n_k].reshape(chi.shape[:-1] + (n_k, 6)) + self.identity_6d
        kept_rot = roma.special_gramschmidt(torch.stack([six[..., :3], six[..., 3:]], dim=-1))
        eye = torch.eye(3, dtype=chi.dtype).expand(chi.shape[:-1] + (3, 3))
        by_joint = {k: kept_rot[..., i, :, :] for i, k in enumerate(self.kept)}
        return torch.stack([by_joint.get(j, eye) for j in range(self.n_joints)], dim=-3)

    def root_positions(self, chi: torch.Tensor, root0=None) -> torch.Tensor:
        """Hips head positions (B, N, 3) in metres: Gamma x gamma_scale, plus ``root0`` (B, 3)."""
        n_k = len(self.kept)
        root = chi[..., 6 * n_k:6 * n_k + 3] * self.gamma_scale
        return root if root0 is None else root + torch.as_tensor(root0, dtype=chi.dtype).reshape(-1, 1, 3)

    def bone_transforms(self, local: torch.Tensor, root: torch.Tensor, heads: torch.Tensor) -> torch.Tensor:
        """Skinning transforms (B, N, J, 3, 4) from local rotations (B, N, J, 3, 3), root (B, N, 3)
        and rest heads (B, J, 3): A_j = [G_j | h_j - G_j r_j]."""
        glob, pos = [local[..., 0, :, :]], [root]
        for j in range(1, self.n_joints):
            p = self.parents[j]
            offset = (heads[:, j] - heads[:, p])[:, None, :, None]  # (B, 1, 3, 1)
            glob.append(glob[p] @ local[..., j, :, :])
            pos.append(pos[p] + (glob[p] @ offset)[..., 0])
        G = torch.stack(glob, dim=-3)
        t = torch.stack(pos, dim=-2) - (G @ heads[:, None, :, :, None])[..., 0]
        return torch.cat([G, t[..., None]], dim=-1)

    def skin(self, transforms: torch.Tensor, rest_vertices: torch.Tensor) -> torch.Tensor:
        """Linear blend skinning: transforms (B, N, J, 3, 4), rest vertices (B, V', 3) -> vertices
        (B, V', N, 3), vertex-major (contiguous: what a loss should compare, see :meth:`forward`)."""
        A = transforms[..., self.bones, :, :]  # (B, N, J', 3, 4)
        n_b, n_f, n_j = A.shape[:3]
        homog = torch.cat([rest_vertices, rest_vertices.new_ones(rest_vertices.shape[:-1] + (1,))], dim=-1)
        design = (self.weights[None, :, :, None] * homog[:, :, None, :]).reshape(n_b, -1, 4 * n_j)
        # rows (j, c), columns (frame, a): one (V', 4J') @ (4J', 3N) product per body
        stacked = A.permute(0, 2, 4, 1, 3).reshape(n_b, 4 * n_j, n_f * 3)
        return torch.bmm(design, stacked).reshape(n_b, -1, n_f, 3)

    # ------------------------------------------------------------------ the path
    def forward(self, chi: torch.Tensor, beta, root0=None, vertex_major: bool = False) -> torch.Tensor:
        """Vertices (B, N, V', 3) of motions chi (B, N, 6K+4) or (N, 6K+4) on bodies beta (B, 6);
        ``root0`` (B, 3) places each first frame (default: the origin).

        ``vertex_major``: return (B, V', N, 3), the layout skinning produces. Losses should
        compare two meshes in this layout: on a transposed view an element-wise loss and its
        backward stride through memory and copy, 5-10x slower than the skinning itself."""
        single = chi.ndim == 2
        chi = (chi[None] if single else chi).to(self.dtype)
        rest_v, heads = self.rest_shape(beta)
        local = self.local_rotations(chi)
        verts = self.skin(self.bone_transforms(local, self.root_positions(chi, root0), heads), rest_v)
        verts = verts if vertex_major else verts.transpose(1, 2)
        return verts[0] if single else verts


def chi_times(chi: torch.Tensor) -> torch.Tensor:
    """Frame times (..., N) in seconds from the cycle start: Phi x PHI_SCALE."""
    return chi[..., -1] * PHI_SCALE
