"""The type prior p(z | motion type) of a latent CCNet: moments by hand, fitting, saving beside a
checkpoint, and the generator's mean output and draws from it."""

from dataclasses import replace

import numpy as np
import pytest
import torch

from ccnet_reference import controls_used, full_recompute_outputs, step_outputs
from data_prep import zoo
from mocapviz import metrics
from mocapviz.features.ccnet import Normaliser
from mocapviz.features.motion_types import MOTION_TYPES, one_hot
from mocapviz.models.ccnet import CCNet
from mocapviz.models.type_prior import TypePrior, moment_matched, sidecar_path
from mocapviz.tasks.type_prior_fit import fit_type_prior, knot_posteriors
from mocapviz.tasks.generate import Generator
from mocapviz.tasks.generation_defaults import GENERATION_MODEL
from mocapviz.training.checkpoint import load_checkpoint, save_checkpoint
from test_ccnet_model import inputs, net, small_cfg


def test_moment_matched_by_hand():
    """Two knots N((0, 0), diag(1, 1)) and N((2, 0), diag(3, 1)): their equal mixture has mean
    (1, 0) and covariance Cov(means) + mean variance = diag(1, 0) + diag(2, 1)."""
    mean, cov = moment_matched(np.array([[0.0, 0.0], [2.0, 0.0]]), np.array([[1.0, 1.0], [3.0, 1.0]]))
    np.testing.assert_allclose(mean, [1.0, 0.0])
    np.testing.assert_allclose(cov, [[3.0, 0.0], [0.0, 1.0]])
    # and against draws from that mixture
    rng = np.random.default_rng(0)
    pick = rng.integers(0, 2, 200_000)
    draws = np.stack([2.0 * pick, np.zeros(len(pick))], 1) + rng.standard_normal((len(pick), 2)) \
        * np.sqrt(np.where(pick[:, None] == 1, [3.0, 1.0], [1.0, 1.0]))
    np.testing.assert_allclose(np.cov(draws.T), cov, atol=0.03)


def test_draw_is_the_mean_plus_the_cholesky_factor_times_the_draws(tmp_path):
    chol = np.array([[[1.0, 0.0], [0.0, 1.0]], [[2.0, 0.0], [1.0, 0.5]]], np.float32)
    prior = TypePrior(np.array([[0.0, 0.0], [1.0, -1.0]], np.float32), chol, np.array([0, 7]))
    z = prior.draw(np.array([1, 0]), np.array([[1.0, 2.0], [3.0, 4.0]], np.float32))
    np.testing.assert_allclose(z, [[1.0 + 2.0, -1.0 + 1.0 + 1.0], [3.0, 4.0]])
    back = TypePrior.load(prior.save(tmp_path / "p.type_prior.safetensors"))
    for k in ("mean", "chol", "counts"):
        np.testing.assert_array_equal(getattr(back, k), getattr(prior, k))
    assert back.phase_hz is None
    prior.phase_hz = np.array([0.0, 1.25], np.float32)
    np.testing.assert_array_equal(TypePrior.load(prior.save(tmp_path / "q.type_prior.safetensors")).phase_hz, [0.0, 1.25])


def toy_clips(cfg, n=4, t=40):
    """Clip dicts as CCNetDataset.clip_arrays gives them, of random numbers: the fit's arithmetic
    is under test here, not motion."""
    rng = np.random.default_rng(1)
    return [dict(x=rng.standard_normal((t, cfg.n_x)).astype(np.float32),
                 traj=rng.standard_normal((t, cfg.n_traj)).astype(np.float32),
                 skel=rng.standard_normal(cfg.n_skel).astype(np.float32), type_index=i % 2) for i in range(n)]


def identity_norm(cfg):
    z = lambda n: np.zeros(n, np.float32)  # noqa: E731
    o = lambda n: np.ones(n, np.float32)   # noqa: E731
    return Normaliser(x_mean=z(cfg.n_continuous), x_std=o(cfg.n_continuous), skel_mean=z(cfg.n_skel),
                      skel_std=o(cfg.n_skel), traj_mean=z(cfg.n_traj), traj_std=o(cfg.n_traj))


def test_fit_pools_the_knots_of_each_type_and_leaves_unseen_types_standard():
    cfg = small_cfg(latent=4, latent_hold=5, latent_lerp=True)
    m, norm = net(cfg), identity_norm(cfg)
    clips = toy_clips(cfg)
    prior = fit_type_prior(m, norm, clips)
    for t in (0, 1):
        post = [knot_posteriors(m, norm, c) for c in clips if c["type_index"] == t]
        mean, cov = moment_matched(np.concatenate([p[0] for p in post]), np.concatenate([p[1] for p in post]))
        np.testing.assert_allclose(prior.mean[t], mean, atol=1e-5)
        np.testing.assert_allclose(prior.chol[t] @ prior.chol[t].T, cov, atol=1e-5)
        assert prior.counts[t] == sum(len(p[0]) for p in post)
    assert prior.phase_hz is None  # a model without a phase input has no use for one
    np.testing.assert_array_equal(prior.mean[2], 0)          # a type the clips lack: N(0, I)
    np.testing.assert_array_equal(prior.chol[2], np.eye(4))
    assert prior.counts[2] == 0
    with pytest.raises(ValueError, match="latent"):
        fit_type_prior(net(small_cfg()), norm, clips)


def test_load_checkpoint_attaches_the_type_prior_beside_it(tmp_path):
    cfg = small_cfg(latent=4)
    m, norm = net(cfg), identity_norm(cfg)
    path = save_checkpoint(tmp_path / "toy.safetensors", m, norm)
    assert load_checkpoint(path)[0].type_prior is None
    prior = fit_type_prior(m, norm, toy_clips(cfg))
    prior.save(sidecar_path(path))
    assert sidecar_path(path).name == "toy.type_prior.safetensors"
    np.testing.assert_array_equal(load_checkpoint(path)[0].type_prior.mean, prior.mean)


@pytest.fixture(scope="module")
def committed():
    return zoo.load("ccnet_default", retrain_if_missing=False)


def latent_model_with_type_prior(committed):
    """The committed network's weights with a blended latent of 4, z's projection made large, and
    a type prior whose means are far from 0 (so that decoding 0 instead would show)."""
    model, norm, _ = committed
    latent = CCNet(replace(model.cfg, latent=4, latent_hold=5, latent_lerp=True)).eval()
    latent.load_state_dict(model.state_dict(), strict=False)
    with torch.no_grad():
        latent.z_in.weight.normal_(0, 1.0)
    rng = np.random.default_rng(0)
    n = model.cfg.n_types
    chol = np.tril(rng.standard_normal((n, 4, 4))).astype(np.float32)
    latent.type_prior = TypePrior(rng.standard_normal((n, 4)).astype(np.float32) * 2, chol, np.ones(n, np.int64))
    return latent, norm


def test_mean_output_with_a_type_prior_equals_full_recompute(ds, committed):
    """The generator's mean output decodes the type's mean z, as the full forward pass does
    (``CCNet.prior_mean``), and not z = 0; switching it off (``type_prior=False``) decodes 0."""
    latent, norm = latent_model_with_type_prior(committed)
    a = ds.clip_arrays(ds.clip_row("HDM_bd_jogLeftCircle4StepsRstart_001_120"))
    x, traj, skel = a["x"][None, :40], a["traj"][None, :40], a["skel"][None]
    types = one_hot([a["type_index"]], latent.cfg.n_types)
    outs = {}
    for use in (True, False):
        g = Generator(latent, norm, type_prior=use)
        g.keep_outputs = True
        gen = g.run(x, skel, types, 60, seed_traj=traj)
        outs[use], pred = step_outputs(g.raw_outputs, latent.cfg)
        if use:
            full = full_recompute_outputs(latent, norm, gen, skel, types, controls_used(gen, traj, pred, norm, latent.cfg))
            assert np.abs(outs[use] - full).max() < 1e-5
    assert np.abs(outs[True] - outs[False]).max() > 1e-2


def test_sampling_draws_z_around_the_types_mean_with_its_covariance(committed):
    """z = mean_type + T L_type e: a temperature scales the type's spread, not its mean."""
    latent, norm = latent_model_with_type_prior(committed)
    prior, ti = latent.type_prior, np.array([MOTION_TYPES.index("wave")])
    for temperature in (1.0, 0.5):
        g = Generator(latent, norm, sample=True, temperature=temperature, seed=3)
        g._type_index = ti
        z = np.concatenate([g._latent(np.zeros((1, latent.cfg.skip_channels), np.float32)) for _ in range(20_000)])
        np.testing.assert_allclose(z.mean(0), prior.mean[ti[0]], atol=0.05 * np.abs(prior.chol[ti[0]]).max())
        cov = temperature ** 2 * prior.chol[ti[0]] @ prior.chol[ti[0]].T
        np.testing.assert_allclose(np.cov(z.T), cov, atol=0.05 * np.abs(cov).max())
    g = Generator(latent, norm)
    g._type_index = ti
    np.testing.assert_array_equal(g._latent(np.zeros((1, latent.cfg.skip_channels), np.float32)), prior.mean[ti])


def test_the_generate_commands_model_has_its_type_prior():
    model, _, _ = zoo.load(GENERATION_MODEL, retrain_if_missing=False)
    prior = model.type_prior
    assert prior is not None and prior.mean.shape == (model.cfg.n_types, model.cfg.latent)
    for name in ("walk", "jog", "wave", "walk_back", "side_step"):   # fitted on many knots
        assert prior.counts[MOTION_TYPES.index(name)] > 500
    # the usual phase paces (the median over each type's training clips): gait rates, a jog's above a walk's
    walk, jog = (prior.phase_hz[MOTION_TYPES.index(t)] for t in ("walk", "jog"))
    assert 0.7 < walk < jog < 1.6, (walk, jog)


@pytest.mark.parametrize("clip", ["dataset-2_wave-both-hands_exhausted_003", "dataset-2_wave-both-hands_elderly_001",
                                  "dataset-2_wave-right-hand_normal_001"])
def test_the_type_prior_steadies_the_sampled_wavings_feet(ds, clip):
    """Sampled 20 s from a Bandai waving take's 1 s seed, seconds 10-20: N(0, I)'s z = 0 decodes
    an average of all types, and the feet step in place (measured: the test seed's sampled jitter
    3.45-3.57x the real wavings'); the type prior's draws cut the feet's jitter by a quarter or
    more (measured 0.50-0.63x on these takes; the feet still move more than the real ones)."""
    model, norm, _ = zoo.load(GENERATION_MODEL, retrain_if_missing=False)
    d = ds.with_vocabulary(model.cfg.n_types)
    row = d.clip_row(clip)
    feet = [d.skeleton(row).index(j) for j in ("LeftFoot", "RightFoot")]
    r, a = d.clips.iloc[row], d.clip_arrays(row)
    jitter = {}
    for use in (True, False):
        gen = Generator(model, norm, sample=True, temperature=0.5, pace="seed", type_prior=use).run(
            a["x"][None, :60], a["skel"][None], one_hot([a["type_index"]], model.cfg.n_types), 1200,
            seed_traj=a["traj"][None, :60])
        late = gen.motion(0, d.skeleton(row), (r.root_x, r.root_y, r.root_z), r.heading, ik=False)[-600:]
        jitter[use] = metrics.jitter(metrics.local_positions(late.positions(), late.skeleton)[:, feet], 60)
    assert jitter[True] < 0.8 * jitter[False], jitter


def test_a_run_from_a_standing_start_keeps_its_legs_moving(data_dir, ds):
    """CMU 127_03 starts standing: its first 2 s show no step cycle, and its phase, turned on at
    the band's floor (0.4 Hz), kept the generated legs nearly still while the body glided on
    (activity 0.16x the real runs' over seconds 30-60 of 60). Turned on at the jog's usual pace
    (TypePrior.phase_hz) the legs run (0.52x over seconds 30-60; here 20 s, seconds 10-20).
    Generated on the training body (the generate command's default since the body change; on
    its own VICON body before): 0.88x with the usual pace, 0.30x without."""
    from dataclasses import replace as with_field

    from mocapviz.tasks.generate_bvh import generate_from_seed, load_seed
    from mocapviz.tasks.generation_quality import References, motion_quality
    from mocapviz.zoo import find_checkpoint

    model, norm, meta = load_checkpoint(find_checkpoint(str(zoo.committed_path(GENERATION_MODEL))))
    refs = References(ds.with_vocabulary(model.cfg.n_types))
    seed = load_seed(data_dir / "cmu" / "127" / "127_03.bvh")
    activity = {}
    for usual_pace in (True, False):
        if not usual_pace:
            model.type_prior = with_field(model.type_prior, phase_hz=None)
        res = generate_from_seed(seed, model, norm, meta, types=["jog"], seconds=20, ik=False)
        on = res.rig.to_model(res.motion)
        late = on[res.n_seed + 600:]
        activity[usual_pace] = motion_quality(late, "jog", refs, float(on.root_positions[:res.n_seed, 1].mean()))[
            "activity_ratio"]
    assert activity[True] > 0.4 and activity[True] > 2 * activity[False], activity
