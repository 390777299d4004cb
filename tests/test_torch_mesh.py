"""The differentiable chi -> mesh path: equal to anny's own path (numpy), and its gradients checked."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mocapviz.bodies.anny_model import body_model
from mocapviz.bodies.representation import PHI_SCALE
from mocapviz.bodies.torch_mesh import ChiMesher, chi_times, skinning_weights


@pytest.fixture(scope="module")
def body():
    return body_model()


@pytest.fixture(scope="module")
def ds(data_dir):
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    return build_dataset(Body4DConfig.quick(), data_dir, progress=False)


def _two_bodies(ds):
    """Two real cycles of different subjects (different betas)."""
    first = ds.cycles.groupby("subject").head(1).index[:2]
    assert len(first) == 2
    return [int(i) for i in first]


def test_equal_to_anny_path(body, ds):
    picks = _two_bodies(ds)
    mesher = ChiMesher(body, ds.gamma_scale)
    root0 = np.array([[0.0, float(ds.cycles["root0_y"].iloc[i]), 0.0] for i in picks])
    with torch.no_grad():
        ours = mesher(torch.as_tensor(ds.chi[picks]), ds.beta[picks], root0=root0).numpy()
    for k, i in enumerate(picks):
        ref = ds.mesh(i, body, on_ground=True).numpy()  # BodyModel.mesh: anny's forward and warp skinning
        assert ours[k].shape == ref.shape == (ds.chi.shape[1], body.n_vertices, 3)
        np.testing.assert_allclose(ours[k], ref, atol=2e-5)
        assert np.abs(ref[1:] - ref[:1]).max() > 0.1  # the body moves: the comparison is not trivial


def test_vertex_subset_and_layout(body, ds):
    i = _two_bodies(ds)[0]
    subset = body.vertex_subset()[:300]
    chi = torch.as_tensor(ds.chi[i])
    with torch.no_grad():
        full = ChiMesher(body, ds.gamma_scale)(chi, ds.beta[i])
        part = ChiMesher(body, ds.gamma_scale, vertices=subset)(chi[None], ds.beta[i:i + 1], vertex_major=True)[0]
    np.testing.assert_allclose(part.transpose(0, 1).numpy(), full[:, subset].numpy(), atol=1e-6)


def test_skinning_weights_partition_unity(body):
    w = skinning_weights(body)
    np.testing.assert_allclose(w.sum(1).numpy(), 1.0, atol=1e-5)


def test_times():
    chi = torch.zeros(2, 5, 10)
    chi[..., -1] = torch.linspace(0, 1, 5)
    np.testing.assert_allclose(chi_times(chi)[0].numpy(), np.linspace(0, PHI_SCALE, 5), rtol=1e-6)


def test_gradcheck_float64(body, ds):
    """torch.autograd.gradcheck of vertices w.r.t. every number of chi: 2 frames, 24 vertices, float64."""
    i = _two_bodies(ds)[0]
    mesher = ChiMesher(body, ds.gamma_scale, vertices=body.vertex_subset()[:24], dtype=torch.float64)
    beta = ds.beta[i:i + 1]
    chi = torch.as_tensor(ds.chi[i:i + 1, ::50], dtype=torch.float64).requires_grad_(True)  # (1, 2, 130)
    assert torch.autograd.gradcheck(lambda c: mesher(c, beta), (chi,), eps=1e-6, atol=1e-6)
    # and a gradient reaches every part of chi that moves vertices: rotations and translation, not time
    g = torch.autograd.grad(mesher(chi, beta).sum(), chi)[0]
    n_theta = 6 * len(mesher.kept)
    assert g[..., :n_theta].abs().sum() > 0 and g[..., n_theta:n_theta + 3].abs().min() > 0
    assert g[..., -1].abs().max() == 0
