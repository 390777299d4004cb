"""4D completion (paper 2 §6): Chamfer on hand cases, the marker set, the semi-synthetic
observations, and a fit from a true mesh's own points that lowers the error."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mocapviz.tasks.cvae4d_completion import (MARKERS, MARKER_VERTICES, CompletionConfig, chamfer, chamfer_loss,
                                              grid, observe, observed_frames, surface_points)


def test_chamfer_by_hand():
    a = np.array([[[0.0, 0, 0], [1, 0, 0]]])
    # a -> b: 0 and 1 (mean 0.5); b -> a: 0; symmetric mean 0.25, squared the same here
    assert chamfer(a, np.array([[[0.0, 0, 0]]]))[0] == pytest.approx(0.25)
    # b = (0, 2, 0): a -> b: 2 and sqrt 5; b -> a: 2 (to the origin)
    far = np.array([[[0.0, 2, 0]]])
    assert chamfer(a, far)[0] == pytest.approx(0.5 * ((2 + np.sqrt(5)) / 2 + 2))
    assert chamfer(a, far, squared=True)[0] == pytest.approx(0.5 * ((4 + 5) / 2 + 4))
    # per frame: two frames, the second shifted by 3 along x
    two = chamfer(np.concatenate([a, a + [3.0, 0, 0]]), np.concatenate([a, a]))
    assert two[0] == 0 and two[1] == pytest.approx(0.5 * (2.5 + 2.5))


def test_chamfer_loss_value_and_gradient_by_hand():
    pred = torch.tensor([[[1.0, 0, 0]]], requires_grad=True)
    obs = torch.tensor([[[0.0, 0, 0], [3, 0, 0]]])
    # pred -> obs: 1 (to the origin); obs -> pred: 1 and 4 (mean 2.5); 0.5 (1 + 2.5)
    loss = chamfer_loss(pred, obs)
    assert float(loss.detach()) == pytest.approx(1.75)
    loss.backward()
    # d/dx of 0.5 ((x - 0)^2 + ((0 - x)^2 + (3 - x)^2) / 2) at x = 1: 0.5 (2 + (2 - 4) / 2) = 0.5
    assert pred.grad[0, 0].tolist() == pytest.approx([0.5, 0, 0])
    # the torch loss with every point equals the numpy Chamfer with squared distances
    rng = np.random.default_rng(0)
    p, o = rng.normal(size=(3, 40, 3)), rng.normal(size=(3, 70, 3))
    t = chamfer_loss(torch.as_tensor(p), torch.as_tensor(o))
    assert float(t) == pytest.approx(float(chamfer(p, o, squared=True).mean()), rel=1e-9)


def test_surface_points_lie_on_the_triangles_by_area():
    verts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 3, 0]])
    faces = np.array([[0, 1, 2], [0, 3, 4]])  # areas 0.5 (z = 0) and 1.5 (x = 0)
    pts = surface_points(verts, faces, 20000, np.random.default_rng(0))
    in_first = (np.abs(pts[:, 2]) < 1e-12) & (pts[:, 0] > 1e-12)
    in_second = np.abs(pts[:, 0]) < 1e-12
    assert np.all(in_first | in_second)
    assert np.all(pts[in_first, 0] + pts[in_first, 1] <= 1 + 1e-12)
    assert np.all(pts[in_second, 2] + pts[in_second, 1] / 3 <= 1 + 1e-12)
    assert in_second.mean() == pytest.approx(0.75, abs=0.015)


def test_observed_frames_and_grid():
    assert observed_frames(100, 5).tolist() == [0, 25, 50, 74, 99]
    assert len(observed_frames(100, 100)) == 100
    fits = grid()
    # Table 1: 4 M x 3 frame counts x 2 variants + 3 markers-only, plus 2 GradNorm checks
    assert len(fits) == 4 * 3 * 2 + 3 + 2
    assert sum(v == "markers" for _, _, v, _ in fits) == 4


@pytest.fixture(scope="module")
def body():
    from mocapviz.bodies.anny_model import body_model
    return body_model()


def test_markers_are_valid_vertices_near_their_joints_on_their_side(body):
    from mocapviz.bodies.anny_model import NEUTRAL_BETA

    assert len(MARKERS) == 16 and len(set(MARKER_VERTICES.tolist())) == 16
    assert MARKER_VERTICES.min() >= 0 and MARKER_VERTICES.max() < body.n_vertices
    rest = body.rest_model(NEUTRAL_BETA)
    v, j = rest["vertices"][0].numpy(), rest["joints"][0].numpy()
    for name, joint, vid in MARKERS:
        assert np.linalg.norm(v[vid] - j[body.index(joint)]) < 0.16, name
        if name[0] in "LR" and name != "C7":  # anny faces +Z with Y up: its left is +X
            assert np.sign(v[vid, 0]) == (1 if name[0] == "L" else -1), name


def test_observations_are_uncorresponded_surface_points_and_marker_vertices(body):
    verts = body.rest_model(np.full(6, 0.5))["vertices"][0].numpy()
    seq = np.repeat(verts[None], 10, axis=0)  # a still body over 10 frames
    obs = observe(seq, body.faces, np.arange(10) / 10, n_points=30, n_frames=4, seed=1)
    assert obs.frames.tolist() == [0, 3, 6, 9] and obs.times.tolist() == pytest.approx([0, 0.3, 0.6, 0.9])
    assert obs.points.shape == (4, 30, 3) and obs.variant == "points+markers"
    assert not np.allclose(obs.points[0], obs.points[1])  # fresh draws per frame
    np.testing.assert_allclose(obs.markers[2], verts[MARKER_VERTICES], atol=1e-6)
    assert observe(seq, body.faces, np.arange(10) / 10, 0, 4).variant == "markers"
    assert observe(seq, body.faces, np.arange(10) / 10, 30, 4, markers=False).markers is None
    with pytest.raises(ValueError):
        observe(seq, body.faces, np.arange(10) / 10, 0, 4, markers=False)


def test_fitting_a_true_cycles_own_points_lowers_the_error(data_dir, body):
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    from mocapviz.bodies.representation import PHI_SCALE
    from mocapviz.tasks.cvae4d_completion import chamfer_error_mm, complete, completion_mesher
    from mocapviz.tasks.cvae4d_eval import on_scale, test_sets
    from mocapviz.zoo import load_cvae4d

    model, meta = load_cvae4d("cvae4d_phase2")
    ds = on_scale(build_dataset(Body4DConfig.quick(), data_dir, progress=False), meta["dataset"]["gamma_scale"])
    i = int(test_sets(ds)["held_out_takes"][0])
    ev = completion_mesher(body, ds.gamma_scale, 1024)
    with torch.no_grad():
        truth = ev(torch.as_tensor(ds.chi[i])[None], torch.as_tensor(ds.beta[i])[None])[0].numpy()
    from mocapviz.bodies.torch_mesh import ChiMesher
    with torch.no_grad():
        full = ChiMesher(body, ds.gamma_scale)(torch.as_tensor(ds.chi[i])[None], torch.as_tensor(ds.beta[i])[None])[0]
    obs = observe(full.numpy(), body.faces, ds.chi[i][:, -1] * PHI_SCALE, n_points=200, n_frames=20, seed=0)
    mesher = completion_mesher(body, ds.gamma_scale, 256)
    start = complete(model, mesher, obs, CompletionConfig(steps=0))  # z = 0, the average adult
    fit = complete(model, mesher, obs, CompletionConfig(steps=40))
    e0 = chamfer_error_mm(ev, start["chi"], start["beta"], truth)
    e1 = chamfer_error_mm(ev, fit["chi"], fit["beta"], truth)
    assert e1 < 0.5 * e0, (e0, e1)
    assert fit["weights"] == {"dense": 1.0, "mocap": 1.0, "time": 1.0}
    losses = fit["losses"]
    assert losses[-1]["mocap"] < 0.2 * losses[0]["mocap"]


def test_committed_table_covers_the_grid():
    import pandas as pd
    from pathlib import Path

    from mocapviz.tasks.cvae4d_completion import FULL_BATCH_FITS

    table = pd.read_csv(Path(__file__).resolve().parents[1] / "results" / "cvae4d_completion.csv")
    assert list(table.columns) == ["M", "frames", "variant", "weighting", "budget", "mean_mm", "n", "seconds"]
    fits = {(m, f, v, w, "minibatch") for m, f, v, w in grid()} | {(m, f, v, w, "full") for m, f, v, w in FULL_BATCH_FITS}
    assert set(zip(table.M, table.frames, table.variant, table.weighting, table.budget)) == fits
    assert (table.n >= 30).all() and table.mean_mm.between(1, 1000).all() and (table.seconds <= 60).all()


def test_summary_keeps_the_budgets_apart():
    import pandas as pd

    from mocapviz.tasks.cvae4d_completion import summary
    rows = pd.DataFrame(dict(M=[50] * 4, frames=[5] * 4, variant=["points"] * 4, weighting=["fixed"] * 4,
                             budget=["minibatch", "minibatch", "full", "full"], error_mm=[10.0, 20.0, 4.0, 6.0],
                             seconds=[1.0, 3.0, 5.0, 7.0]))
    out = summary(rows).set_index("budget")
    assert out.loc["minibatch", "mean_mm"] == 15.0 and out.loc["full", "mean_mm"] == 5.0
    assert out.loc["full", "n"] == 2 and out.loc["full", "seconds"] == 6.0


def test_shard_option_is_checked():
    import argparse

    from data_prep.cvae4d_completion import _shard

    p = argparse.ArgumentParser()
    assert _shard(p, "1/2") == (1, 2)
    for bad in ("2/2", "-1/2", "1", "a/b"):
        with pytest.raises(SystemExit):
            _shard(p, bad)
