"""CCNet generation with the committed checkpoint: incremental = full recompute, IK, zoo."""

from dataclasses import replace

import numpy as np
import pytest
import torch

from ccnet_reference import controls_used, full_recompute_outputs, step_outputs
from data_prep import zoo
from mocapviz.features.motion_types import one_hot
from mocapviz.ik import foot_joints, remove_foot_sliding
from mocapviz import metrics
from mocapviz.metrics import foot_sliding
from mocapviz.models.ccnet import CCNet
from mocapviz.models.steppers import CCNetStepper, NumpyStepper
from mocapviz.tasks.generate import Generator, at_speed, plan_speed
from mocapviz.tasks.generation_defaults import GENERATION_MODEL


@pytest.fixture(scope="module")
def committed():
    path = zoo.committed_path("ccnet_default")
    if not path.is_file():
        pytest.fail(f"the committed checkpoint {path} is missing")
    return zoo.load("ccnet_default", retrain_if_missing=False)


def test_committed_checkpoint_is_small_and_self_contained(committed):
    model, norm, meta = committed
    assert zoo.committed_path("ccnet_default").stat().st_size < 10 * 2 ** 20
    assert model.cfg.receptive_field == 41 and not model.training
    assert meta["dataset"]["joint_names"][0] == "Hips" and len(norm.x_mean) == model.cfg.n_continuous
    assert "optim_param_groups" not in meta  # model-only export


def seed_inputs(ds, clip, n_seed=40):
    row = ds.clip_row(clip)
    a = ds.clip_arrays(row)
    return row, a["x"][None, :n_seed], a["traj"][None, :n_seed], a["skel"][None], a["type_index"]


@pytest.mark.parametrize("residual", ["none", "all"])
@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_incremental_generation_equals_full_recompute(ds, committed, backend, residual):
    model, norm, _ = committed
    if residual != "none":  # the same weights as a residual network: the generator adds x_t to the mean
        model = CCNet(replace(model.cfg, residual=True)).eval()
        model.load_state_dict(committed[0].state_dict())
    _, x, traj, skel, ti = seed_inputs(ds, "HDM_bd_jogLeftCircle4StepsRstart_001_120")
    types = one_hot([ti], model.cfg.n_types)
    g = Generator(model, norm, backend=backend)
    g.keep_outputs = True
    gen = g.run(x, skel, types, 200, seed_traj=traj)
    inc, pred = step_outputs(g.raw_outputs, model.cfg)
    s = x.shape[1]
    used = controls_used(gen, traj, pred, norm, model.cfg)
    with torch.inference_mode():
        full = full_recompute_outputs(model, norm, gen, skel, types, used)
    # (the committed weights run as a residual network drift to means of ~1e2: float32 rounding
    # is then relative)
    assert np.abs(inc - full).max() < 1e-5 * (np.abs(full).max() if residual != "none" else 1.0)
    # the generated frames are the fed-back means (not copies of the seed), except the channels
    # constant in training, which hold their training value (0 normalised)
    n, const = model.cfg.n_continuous, norm.constant_channels()
    assert np.array_equal(gen.x_norm[0, s:, :n][:, ~const], inc[0, s - 1:, :n][:, ~const])
    assert const.any() and not gen.x_norm[0, s:, :n][:, const].any()
    # constant_channels() marks the channels constant in the normaliser's training data (the
    # committed model's normaliser predates dataset v4, so check it on this dataset's own)
    train = np.concatenate([np.arange(r.start, r.stop) for r in ds.clips.itertuples() if r.split == "train"])
    np.testing.assert_array_equal(ds.normaliser.constant_channels(), ds.x[train, :n].std(0) < 1e-4)


def test_numpy_and_torch_steppers_agree(committed):
    model, _, _ = committed
    cfg = model.cfg
    rng = np.random.default_rng(0)
    a, b = NumpyStepper(model, 3), CCNetStepper(model, 3)
    skel, types = rng.normal(size=(3, cfg.n_skel)).astype(np.float32), np.eye(cfg.n_types, dtype=np.float32)[:3]
    a.set_static(skel, types)
    b.set_static(torch.from_numpy(skel), torch.from_numpy(types))
    with torch.inference_mode():
        for _ in range(45):
            x = rng.normal(size=(3, cfg.n_x)).astype(np.float32)
            c = rng.normal(size=(3, cfg.n_traj)).astype(np.float32)
            np.testing.assert_allclose(a.step(x, c), b.step(torch.from_numpy(x), torch.from_numpy(c)).numpy(),
                                       atol=2e-5)


FROZEN_DEFAULT = pytest.mark.xfail(strict=True, reason="measured: ccnet_default (dataset v4, 90% Bandai) keeps "
                                   "Bandai seeds moving but not the held-out HDM05 subject's jog nor CMU 91's walk")


@pytest.mark.parametrize("name, clip", [
    pytest.param("ccnet_default", "HDM_tr_jogLeftCircle4StepsRstart_014_120", marks=FROZEN_DEFAULT),
    pytest.param("ccnet_default", "91_02", marks=FROZEN_DEFAULT),
    ("ccnet_generate", "HDM_tr_jogLeftCircle4StepsRstart_014_120"),
    ("ccnet_generate", "91_02"),
])
def test_generated_motion_keeps_moving(ds, name, clip):
    """10 s free-running (the network's own c^d) from a 1 s seed: the held-out subject jogging
    and a CMU subject walking keep moving at a good share of their clip's speed, never freeze
    (pose-level: no 1 s window of root-relative joint positions under 1 cm/s)."""
    model, norm, _ = zoo.load(name, retrain_if_missing=False)
    row, x, traj, skel, ti = seed_inputs(ds, clip, 60)
    r = ds.clips.iloc[row]
    clip_root = ds.clip_motion(row).root_positions
    speed = np.linalg.norm(np.diff(clip_root[:, [0, 2]], axis=0), axis=1).mean() * 60
    n = 600
    gen = Generator(model, norm).run(x, skel, one_hot([ti], model.cfg.n_types), n, seed_traj=traj)
    m = gen.motion(0, ds.skeleton(row), (r.root_x, r.root_y, r.root_z), r.heading, ik=False)
    moving = m[60:]
    assert metrics.freezing_share(metrics.local_positions(moving.positions(), moving.skeleton), m.fps) == 0.0
    last5 = np.linalg.norm(np.diff(m.root_positions[-300:, [0, 2]], axis=0), axis=1).sum() / 5.0
    assert last5 > 0.5 * speed  # still moving in the last 5 s
    assert 0.6 < m.root_positions[60:, 1].mean() / clip_root[:, 1].mean() < 1.3  # upright, not sinking


# the root from the past alone (root_without_z) reads the tall bodies' height worse than S1 did
ROOT_HEIGHT_DROP = pytest.mark.xfail(strict=True, reason=(
    "measured: ccnet_generate (the root decoded without z) drops the tall bodies on the first "
    "generated frame: the held-out tr jog 0.940 -> 0.852 m, CMU 35 1.000 -> 0.794 (ccnet_phase_lerp_scale: "
    "0.924); Bandai's and CMU 91's body keep their height"))


@pytest.mark.parametrize("name, clip", [
    ("ccnet_generate", "dataset-2_walk-turn-left_active_005"),     # Bandai's body
    ("ccnet_generate", "91_02"),                                   # CMU 91: 0.81 m standing root height, Bandai's is 0.83
    pytest.param("ccnet_generate", "HDM_tr_jogLeftCircle4StepsRstart_014_120", marks=ROOT_HEIGHT_DROP),
    pytest.param("ccnet_generate", "35_01", marks=ROOT_HEIGHT_DROP),  # CMU 35: 0.97 m
])
def test_first_generated_frame_keeps_the_bodys_root_height(ds, clip, name):
    """The first generated frame continues the seed's root height (a real root moves millimetres
    per frame at 60 fps): a body other than Bandai's must not sink or rise at the seed's end."""
    model, norm, _ = zoo.load(name, retrain_if_missing=False)
    row, x, traj, skel, ti = seed_inputs(ds, clip, 48)
    out = Generator(model, norm).run(x, skel, one_hot([ti], model.cfg.n_types), 5, seed_traj=traj)
    r = ds.clips.iloc[row]
    h = out.motion(0, ds.skeleton(row), (r.root_x, r.root_y, r.root_z), r.heading, ik=False).root_positions[:, 1]
    assert abs(h[48] - h[47]) < 0.03, f"root height {h[47]:.3f} -> {h[48]:.3f} m at the first generated frame"


def test_foot_lock_puts_a_carried_foot_down_again():
    """A foot labelled in contact while the body carries it along at 0.9 m/s (a gliding generated
    root) is held where it is, and put down again each time it has drifted MAX_SLIP from the
    hold: the legs are never pulled level behind the body. A foot that stays near its hold keeps
    one hold for the whole run, as before."""
    from mocapviz.ik import MAX_SLIP, foot_lock_targets
    t = np.arange(120) / 60.0
    carried = np.stack([t * 0.9, np.full_like(t, 0.1), np.zeros_like(t)], 1)   # 0.9 m/s along X
    target = foot_lock_targets(carried, np.ones(120, dtype=bool))
    lag = carried[:, 0] - target[:, 0]
    assert lag.max() <= MAX_SLIP and lag.min() >= 0 and len(np.unique(target[:, 0])) == 9  # 1.8 m in holds of 14 frames
    np.testing.assert_array_equal(target[:, 1], carried[:, 1])              # the height stays free
    still = carried * [0.05, 1, 1]                                           # 0.09 m in the run: one hold
    np.testing.assert_array_equal(foot_lock_targets(still, np.ones(120, dtype=bool))[:, 0], 0.0)


def test_foot_ik_removes_sliding_and_keeps_bones(ds):
    row = ds.clip_row("35_01")
    m = ds.clip_motion(row)
    assert m.name == "35_01"  # the clip's name (it was pandas' Series.clip method)
    contacts = m.meta["contacts"]
    before = foot_sliding(m.positions(), contacts, m.fps, foot_joints(m.skeleton))
    out = remove_foot_sliding(m, contacts)
    after = foot_sliding(out.positions(), contacts, out.fps, foot_joints(out.skeleton))
    assert before > 0.05 and after < 0.25 * before
    bones = lambda mo: np.linalg.norm(mo.positions()[:, 1:] - mo.positions()[:, mo.skeleton.parents[1:]], axis=-1)  # noqa: E731
    np.testing.assert_allclose(bones(out), bones(m), atol=1e-9)
    # the root and every joint outside the legs stay where they were
    legs = [m.skeleton.index(n) for n in ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
                                          "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase")]
    others = [j for j in range(m.skeleton.n_joints) if j not in legs]
    np.testing.assert_allclose(out.positions()[:, others], m.positions()[:, others], atol=1e-9)


def test_sampling_temperature_scales_the_draw_around_the_mean(ds, committed):
    """The first sampled frame is mean + temperature * sigma * noise with the same noise: at
    temperature 0 it is the mean output, at 0.5 half the distance of temperature 1."""
    model, norm, _ = committed
    _, x, traj, skel, ti = seed_inputs(ds, "HDM_bd_jogLeftCircle4StepsRstart_001_120")
    types = one_hot([ti], model.cfg.n_types)
    first = {}
    for key, kw in {"mean": dict(sample=False), 0.0: dict(sample=True, temperature=0.0),
                    0.5: dict(sample=True, temperature=0.5), 1.0: dict(sample=True, temperature=1.0)}.items():
        gen = Generator(model, norm, seed=3, **kw).run(x, skel, types, 1, seed_traj=traj)
        first[key] = gen.x_norm[0, -1, :model.cfg.n_continuous]
    np.testing.assert_array_equal(first[0.0], first["mean"])
    away = first[1.0] - first["mean"]
    assert np.abs(away).max() > 0.01
    np.testing.assert_allclose(first[0.5] - first["mean"], 0.5 * away, atol=1e-5)
    with pytest.raises(ValueError, match="temperature"):
        Generator(model, norm, sample=True, temperature=-1)


def test_latent_model_samples_z_and_writes_the_decoders_mean(ds, committed):
    """A latent CCNet (CCNetConfig.latent) samples z ~ N(0, T^2 I) per frame and writes the
    decoder's mean (no per-frame Gaussian noise); temperature 0 or the mean output use z = 0."""
    model, norm, _ = committed
    latent = CCNet(replace(model.cfg, latent=4)).eval()
    latent.load_state_dict(model.state_dict(), strict=False)
    with torch.no_grad():
        latent.z_in.weight.normal_(0, 1.0)
    _, x, traj, skel, ti = seed_inputs(ds, "HDM_bd_jogLeftCircle4StepsRstart_001_120")
    types = one_hot([ti], model.cfg.n_types)
    run = lambda **kw: Generator(latent, norm, **kw).run(x, skel, types, 60, seed_traj=traj)  # noqa: E731
    mean, cold = run(), run(sample=True, temperature=0.0)
    g = Generator(latent, norm, sample=True, seed=1)
    g.keep_outputs = True
    hot = g.run(x, skel, types, 60, seed_traj=traj)
    inc, _ = step_outputs(g.raw_outputs, latent.cfg)
    s, n, const = x.shape[1], latent.cfg.n_continuous, norm.constant_channels()
    np.testing.assert_array_equal(cold.x_norm, mean.x_norm)
    assert np.abs(hot.x_norm[0, s:, :n] - mean.x_norm[0, s:, :n]).max() > 0.1
    np.testing.assert_array_equal(hot.x_norm[0, s:, :n][:, ~const], inc[0, s - 1:, :n][:, ~const])


def test_held_latent_draws_a_new_z_every_latent_hold_frames(ds, committed):
    """With CCNetConfig.latent_hold k the generator draws z at frames 0, k, 2k, ... and keeps it."""
    model, norm, _ = committed
    latent = CCNet(replace(model.cfg, latent=4, latent_hold=5)).eval()
    latent.load_state_dict(model.state_dict(), strict=False)
    g = Generator(latent, norm, sample=True, seed=1)
    drawn = []
    draw = g._latent
    g._latent = lambda skip: drawn.append(draw(skip)) or drawn[-1]
    _, x, traj, skel, ti = seed_inputs(ds, "35_01")
    g.run(x, skel, one_hot([ti], model.cfg.n_types), 30, seed_traj=traj)
    assert len(drawn) == -(-(x.shape[1] + 30 - 1) // 5)   # one per 5 of the steps
    assert not np.array_equal(drawn[0], drawn[1])


def test_blended_latent_feeds_the_decoder_a_continuous_z(ds, committed):
    """latent_lerp with k: the generator draws a knot every k frames (two at the start), and the
    z the decoder sees is their linear blend: its path has no jumps and bends only at knots."""
    model, norm, _ = committed
    latent = CCNet(replace(model.cfg, latent=4, latent_hold=5, latent_lerp=True)).eval()
    latent.load_state_dict(model.state_dict(), strict=False)
    g = Generator(latent, norm, sample=True, seed=1)
    seen, knots = [], []
    head, draw = g._head, g._latent
    g._head = lambda skip, z, c: seen.append(z.copy()) or head(skip, z, c)
    g._latent = lambda skip: knots.append(draw(skip)) or knots[-1]
    _, x, traj, skel, ti = seed_inputs(ds, "35_01")
    g.run(x, skel, one_hot([ti], model.cfg.n_types), 30, seed_traj=traj)
    z = np.stack(seen)[:, 0]                                             # (steps, latent)
    steps = x.shape[1] + 30 - 1
    assert len(knots) == -(-steps // 5) + 1
    np.testing.assert_allclose(z[::5], np.stack(knots)[:-1, 0][:len(z[::5])], atol=1e-6)
    np.testing.assert_allclose(z[7], 0.6 * knots[1][0] + 0.4 * knots[2][0], atol=1e-6)
    bend = np.abs(z[2:] + z[:-2] - 2 * z[1:-1]).max(-1)
    at_knot = (np.arange(1, len(z) - 1) % 5) == 0
    assert bend[~at_knot].max() < 1e-5 and bend[at_knot].min() > 1e-3


def test_correlated_draws_keep_unit_variance_with_the_asked_lag_one_correlation(committed):
    model, norm, _ = committed
    for rho in (0.0, 0.9):
        g = Generator(model, norm, sample=True, noise_correlation=rho)
        e = np.stack([g._draw((1, 200))[0] for _ in range(5000)])          # (frames, channels)
        lag1 = np.mean([np.corrcoef(e[:-1, j], e[1:, j])[0, 1] for j in range(e.shape[1])])
        assert abs(e.std() - 1.0) < 0.02 and abs(lag1 - rho) < 0.01
    with pytest.raises(ValueError, match="noise_correlation"):
        Generator(model, norm, noise_correlation=1.0)


def test_nan_seed_controls_are_the_networks_own(ds, committed):
    """seed_traj rows that are NaN take the c^d the generator would use without a seed c^d (the
    network's prediction here): all-NaN equals no seed c^d; with a NaN tail the generated
    frames differ from both (the given rows are used, the NaN ones are not)."""
    model, norm, _ = committed
    _, x, traj, skel, t = seed_inputs(ds, "35_01")
    types = one_hot([t], model.cfg.n_types)
    run = lambda st: Generator(model, norm).run(x, skel, types, 30, seed_traj=st).x  # noqa: E731
    assert np.array_equal(run(np.full_like(traj, np.nan)), run(None))
    tail = traj.copy()
    tail[:, 20:] = np.nan
    own, given, mixed = run(np.full_like(traj, np.nan)), run(traj), run(tail)
    assert not np.array_equal(mixed[:, 40:], given[:, 40:]) and not np.array_equal(mixed[:, 40:], own[:, 40:])


def test_plan_speed_and_at_speed_on_hand_made_plans():
    """A plan 0.2 m further every 10 frames (60 fps) is 1.2 m/s; one 0.6 m to the side at frame
    10, then 0.6 m straight ahead of the root from frame 20 on, covers 0.6 + 0.6 sqrt(2) m in its second; at_speed scales the
    points about the root to the asked speed and leaves the phase columns alone; a still plan has no
    direction to stretch and stays still."""
    ahead = np.zeros((1, 14), np.float32)
    ahead[0, 1:12:2] = 0.2 * np.arange(1, 7)                      # z ahead of the root
    ahead[0, 12:] = (0.6, 0.8)                                     # a phase model's (sin, cos)
    corner = np.zeros((1, 12), np.float32)
    corner[0, 0] = 0.6                                             # x: 0.6 m to the side at frame 10
    corner[0, 3::2] = 0.6                                          # z: 0.6 m ahead from frame 20 on
    np.testing.assert_allclose(plan_speed(ahead), [1.2], rtol=1e-6)
    np.testing.assert_allclose(plan_speed(corner), [0.6 + 0.6 * np.sqrt(2)], rtol=1e-6)
    slow = at_speed(np.concatenate([ahead[:, :12], corner]), np.array([0.3, 2.0]))
    np.testing.assert_allclose(plan_speed(slow), [0.3, 2.0], rtol=1e-6)
    np.testing.assert_allclose(slow[0], ahead[0, :12] * 0.25, rtol=1e-6)
    np.testing.assert_array_equal(at_speed(ahead, np.array([0.3]))[0, 12:], ahead[0, 12:])
    assert not at_speed(np.zeros((1, 12), np.float32), np.array([1.5])).any()


def test_seed_pace_feeds_the_networks_plan_at_the_seeds_last_speed(ds):
    """pace="seed": every generated frame is fed the network's predicted c^d scaled to the speed of
    the seed's last c^d (a phase model: its phase columns as without pace), and the stepper's
    outputs equal one full forward pass over those controls."""
    model, norm, _ = zoo.load(GENERATION_MODEL, retrain_if_missing=False)
    d = ds.with_vocabulary(model.cfg.n_types)
    _, x, traj, skel, ti = seed_inputs(d, "dataset-2_run_masculine_047", 48)
    types = one_hot([ti], model.cfg.n_types)
    g = Generator(model, norm, pace="seed")
    g.keep_outputs = True
    gen = g.run(x, skel, types, 120, seed_traj=traj)
    inc, pred = step_outputs(g.raw_outputs, model.cfg)
    s, n_plan = x.shape[1], len(norm.traj_mean)
    speed = plan_speed(traj[:, s - 1])
    assert speed[0] > 2.0  # a run
    plans = at_speed((pred[0, s - 2:-1, :n_plan] * norm.traj_std + norm.traj_mean), np.repeat(speed, len(pred[0]) - s + 1))
    used = controls_used(gen, traj, pred, norm, model.cfg)
    used[0, s - 1:, :n_plan] = norm.norm_traj(plans)
    with torch.inference_mode():
        full = full_recompute_outputs(model, norm, gen, skel, types, used)
    assert np.abs(inc - full).max() < 1e-5
    np.testing.assert_allclose(plan_speed(plans), speed[0], rtol=1e-5)
    with pytest.raises(ValueError, match="pace"):
        Generator(model, norm, pace="user")


def test_seed_pace_keeps_a_run_running(ds):
    """A held-out Bandai run seed, 20 s with the generate command's model, mean output, last 5 s:
    with z = 0 (N(0, I)'s mean) and fed its own plan the network slows to about half the seed
    plan's ground speed (0.46x measured); at the seed's pace it keeps running (0.84x measured).
    With the run's mean z (its type prior) it keeps running either way (1.09x, 0.99x)."""
    model, norm, _ = zoo.load(GENERATION_MODEL, retrain_if_missing=False)
    d = ds.with_vocabulary(model.cfg.n_types)
    row, x, traj, skel, ti = seed_inputs(d, "dataset-2_run_masculine_047", 48)
    r = d.clips.iloc[row]
    target = plan_speed(traj[:, -1])[0]
    last5 = {}
    for pace in ("network", "seed"):
        for type_prior in (False, True):
            gen = Generator(model, norm, pace=pace, type_prior=type_prior).run(
                x, skel, one_hot([ti], model.cfg.n_types), 1200, seed_traj=traj)
            root = gen.motion(0, d.skeleton(row), (r.root_x, r.root_y, r.root_z), r.heading, ik=False).root_positions
            last5[pace, type_prior] = np.linalg.norm(np.diff(root[-300:, [0, 2]], axis=0), axis=1).sum() / 5.0 / target
    assert last5["network", False] < 0.6 and 0.75 < last5["seed", False] < 1.25, last5
    assert 0.75 < last5["network", True] < 1.25 and 0.75 < last5["seed", True] < 1.25, last5


def test_seed_pace_ends_where_the_motion_type_changes(ds):
    """A type schedule that switches at the first generated frame leaves the seed's pace behind:
    the generation equals the network's own pace (a walk turned run must not keep the walk's
    speed), while without a switch the held pace changes the frames."""
    model, norm, _ = zoo.load(GENERATION_MODEL, retrain_if_missing=False)
    d = ds.with_vocabulary(model.cfg.n_types)
    _, x, traj, skel, ti = seed_inputs(d, "dataset-2_walk_active_019", 48)
    run = d.meta["motion_types"].index("jog")
    switched = one_hot([ti] * 48 + [run] * 60, model.cfg.n_types)[None]
    kept = one_hot([ti] * 108, model.cfg.n_types)[None]
    gen = {(pace, name): Generator(model, norm, pace=pace).run(x, skel, types, 60, seed_traj=traj).x
           for pace in ("seed", "network") for name, types in (("switched", switched), ("kept", kept))}
    np.testing.assert_array_equal(gen["seed", "switched"], gen["network", "switched"])
    assert not np.allclose(gen["seed", "kept"], gen["network", "kept"])
