"""CCNet network: causality, receptive field (Eq. 3), incremental = full, NLL by hand, checkpoints."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from mocapviz.features.ccnet import Normaliser
from mocapviz.models.ccnet import CCNet
from mocapviz.models.ccnet_extensions import latent_weights
from mocapviz.models.ccnet_config import CCNetConfig, receptive_field
from mocapviz.models.steppers import CCNetStepper
from mocapviz.training.checkpoint import load_checkpoint, save_checkpoint
from mocapviz.training.losses import ccnet_loss, gaussian_nll, smoothness


def small_cfg(dilations=(2,) * 20, **kw):
    return CCNetConfig(n_x=30, n_skel=7, n_traj=12, n_types=3, channels=8, skip_channels=8,
                       dilations=dilations, **kw)


def inputs(cfg, b=2, t=90, seed=0):
    g = torch.Generator().manual_seed(seed)
    x = torch.randn(b, t, cfg.n_x, generator=g)
    skel = torch.randn(b, cfg.n_skel, generator=g)
    traj = torch.randn(b, t, cfg.n_traj, generator=g)
    types = torch.zeros(b, cfg.n_types)
    types[:, 1] = 1
    return x, skel, traj, types


def net(cfg, seed=0):
    torch.manual_seed(seed)
    m = CCNet(cfg).eval()
    with torch.no_grad():  # larger output weights so that every input visibly moves the output
        m.decoder.weight.mul_(10)
    return m


def outputs(m, x, skel, traj, types):
    with torch.no_grad():
        o = m(x, skel, traj, types)
    return torch.cat([o["mean"], o["sigma"], o["contact_logits"], o["traj_mean"]], -1)


def test_causality_changing_frame_t_leaves_earlier_outputs():
    cfg = small_cfg()
    m = net(cfg)
    x, skel, traj, types = inputs(cfg)
    base = outputs(m, x, skel, traj, types)
    for t in (0, 17, 50, 89):
        x2, traj2 = x.clone(), traj.clone()
        x2[:, t] += 1.0
        traj2[:, t] -= 1.0
        out = outputs(m, x2, skel, traj2, types)
        assert torch.equal(out[:, :t], base[:, :t])
        assert (out[:, t] - base[:, t]).abs().max() > 1e-3


@pytest.mark.parametrize("dilations", [(2,) * 20, (1, 2) * 10, (1, 2, 4) * 6 + (1, 2), (1,) * 5, (3, 7, 1)])
def test_receptive_field_equals_eq3(dilations):
    cfg = small_cfg(dilations)
    crl = receptive_field(dilations)
    assert crl == 1 + sum(dilations) == cfg.receptive_field
    m = net(cfg, seed=1)
    t_out = crl + 10
    x, skel, traj, types = inputs(cfg, b=1, t=t_out + 1)
    x.requires_grad_(True)
    m(x, skel, traj, types)["mean"][0, t_out].sum().backward()
    seen = np.flatnonzero(x.grad[0].abs().sum(-1).numpy() > 0)
    # the span of input frames reaching output t is exactly CRL (Eq. 3)
    assert seen.min() == t_out - crl + 1 and seen.max() == t_out
    if all(d == 2 for d in dilations):  # the paper's d = 2 everywhere sees every other frame only
        assert len(seen) == (crl + 1) // 2


def test_paper_default_receptive_field_is_41():
    assert CCNetConfig().receptive_field == 41


@pytest.mark.parametrize("dilations", [(2,) * 20, (1, 2, 4) * 3])
@pytest.mark.parametrize("batch", [1, 3])
def test_incremental_equals_full_recompute(dilations, batch):
    cfg = small_cfg(dilations)
    m = net(cfg)
    x, skel, traj, types = inputs(cfg, b=batch, t=70)
    with torch.no_grad():
        full = m(x, skel, traj, types)
        raw_full = torch.cat([full["mean"], -torch.log(full["sigma"]), full["contact_logits"],
                              full["traj_mean"]], -1)
    st = CCNetStepper(m, batch)
    st.set_static(skel, types)
    with torch.inference_mode():
        steps = torch.stack([st.step(x[:, t], traj[:, t]) for t in range(x.shape[1])], 1)
    n = cfg.n_continuous
    keep = torch.cat([steps[..., :2 * n + cfg.n_contact], steps[..., 2 * n + cfg.n_contact:][..., :cfg.n_traj]], -1)
    # sigma is clipped at 1e-4 in the full model; compare raw s only where it is not clipped
    s_full = raw_full[..., n:2 * n]
    unclipped = full["sigma"] > cfg.sigma_min
    assert torch.allclose(keep[..., :n], raw_full[..., :n], atol=1e-5)
    assert torch.allclose(keep[..., n:2 * n][unclipped], s_full[unclipped], atol=1e-5)
    assert torch.allclose(keep[..., 2 * n:], raw_full[..., 2 * n:], atol=1e-5)


def stepped(m, backend, x, skel, traj, types, z):
    """The raw outputs (B, T, n_out) of ``m``'s stepper on ``backend``, one frame (and z) per call."""
    st = m.stepper(x.shape[0], backend)
    conv = (lambda a: a) if backend == "torch" else (lambda a: a.numpy())
    st.set_static(conv(skel), conv(types))
    with torch.inference_mode():
        return torch.stack([torch.as_tensor(st.step(conv(x[:, t]), conv(traj[:, t]), conv(z[:, t])))
                            for t in range(x.shape[1])], 1)


def test_denorm_traj_inverts_norm_traj_and_drops_the_phase_columns():
    """A phase model's c^d (12 ground points, then an unnormalised (sin, cos)) comes back as the
    raw ground points."""
    from mocapviz.features.ccnet import FeatureLayout
    layout = FeatureLayout(n_joints=25)
    rng = np.random.default_rng(1)
    traj = rng.normal(0.5, 0.3, (200, 12)).astype(np.float32)
    nm = Normaliser.fit(rng.normal(size=(200, layout.n_x)).astype(np.float32),
                        rng.normal(size=(200, layout.n_skel)).astype(np.float32), traj, layout.n_x - 2)
    with_phase = np.concatenate([nm.norm_traj(traj[:3]), [[0.6, 0.8]] * 3], axis=1)
    back = nm.denorm_traj(with_phase)
    assert back.shape == (3, 12)
    np.testing.assert_allclose(back, traj[:3], atol=1e-6)


def test_body_scaled_normaliser_is_the_scaled_bodies_statistics():
    """Normaliser.body_scaled(lo, hi): c^s's mean and std those of s c^s over frames, s ~ U(lo, hi)
    independent of c^s (checked against every frame at 2001 evenly spread s); a constant channel
    (stored std 1) scales with s, a zero one stays unscaled."""
    rng = np.random.default_rng(2)
    skel = np.stack([rng.normal(0.85, 0.03, 300), np.full(300, 0.4), np.zeros(300)], 1).astype(np.float32)
    nm = Normaliser.fit(rng.normal(size=(300, 6)).astype(np.float32), skel, rng.normal(size=(300, 2)), 4)
    assert nm.skel_std[1] == nm.skel_std[2] == 1.0
    s = np.linspace(0.9, 1.25, 2001)
    seen = (s[:, None, None] * skel.astype(np.float64)[None]).reshape(-1, 3)
    scaled = nm.body_scaled(0.9, 1.25)
    np.testing.assert_allclose(scaled.skel_mean, seen.mean(0), rtol=1e-5)
    np.testing.assert_allclose(scaled.skel_std[:2], seen.std(0)[:2], rtol=2e-3)
    assert scaled.skel_std[2] == 1.0
    np.testing.assert_array_equal(scaled.x_std, nm.x_std)


def test_residual_mean_adds_the_input_frame():
    plain, res = net(small_cfg()), CCNet(small_cfg(residual=True)).eval()
    res.load_state_dict(plain.state_dict())
    x, skel, traj, types = inputs(small_cfg())
    with torch.no_grad():
        a, b = plain(x, skel, traj, types), res(x, skel, traj, types)
    n = small_cfg().n_continuous
    assert torch.allclose(b["mean"], a["mean"] + x[..., :n])
    assert all(torch.equal(a[k], b[k]) for k in ("sigma", "contact_logits", "traj_mean", "traj_sigma"))
    # a config saved before the option existed loads as the paper's non-residual network
    assert not CCNetConfig.from_json(small_cfg(residual=True).to_json().replace(', "residual": true', "")).residual


def test_fed_back_inputs_are_the_models_own_means():
    from mocapviz.training.trainer import fed_back, model_inputs
    cfg = small_cfg(residual=True)
    m = net(cfg)
    x, skel, traj, types = inputs(cfg, t=10)
    varying = torch.ones(cfg.n_continuous, dtype=torch.bool)
    varying[0] = False
    b = dict(x=x, skel=skel, traj=traj, types=types, varying=varying)
    with torch.no_grad():
        mean = m(x, skel, traj, types)["mean"]
        fed_inputs = model_inputs(m, b)
        once, twice = fed_back(m, b, fed_inputs, 1), fed_back(m, b, fed_inputs, 2)
        mean2 = m(once, skel, traj, types)["mean"]
    n = cfg.n_continuous
    assert torch.equal(once[:, :5], x[:, :5])                        # first half: the data
    assert torch.equal(once[:, 5:, 1:n], mean[:, 4:-1, 1:])          # frame t: the mean predicted at t-1
    assert torch.equal(once[:, 5:, 0], x[:, 5:, 0]) and torch.equal(once[..., n:], x[..., n:])
    assert torch.equal(twice[:, 5:, 1:n], mean2[:, 4:-1, 1:])        # the second pass feeds the first's


def test_rolled_out_inputs_run_free_from_start():
    """Each rolled-out frame is the full forward's mean on the rolled-out inputs before it (a
    free-running generation, residual rule included); the seed, constant channels and contacts
    stay the data's."""
    from mocapviz.training.trainer import rolled_out
    cfg = small_cfg(residual=True)
    m = net(cfg)
    x, skel, traj, types = inputs(cfg, t=12)
    varying = torch.ones(cfg.n_continuous, dtype=torch.bool)
    varying[3] = False
    b = dict(x=x, skel=skel, traj=traj, types=types, varying=varying)
    rolled = rolled_out(m, b, start=5)
    with torch.no_grad():
        mean = m(rolled, skel, traj, types)["mean"]
    n = cfg.n_continuous
    assert torch.equal(rolled[:, :5], x[:, :5])
    assert torch.allclose(rolled[:, 5:, :n][..., varying], mean[:, 4:-1][..., varying], atol=1e-5)
    assert torch.equal(rolled[:, 5:, 3], x[:, 5:, 3]) and torch.equal(rolled[..., n:], x[..., n:])
    assert not torch.allclose(rolled[:, 5:, :n], x[:, 5:, :n])


def test_gaussian_nll_hand_computed():
    x = torch.tensor([1.0, -2.0])
    mu = torch.tensor([0.5, 0.0])
    sigma = torch.tensor([2.0, 0.1])
    expect = [math.log(2.0) + 0.5 * (0.5 / 2.0) ** 2 + 0.5 * math.log(2 * math.pi),
              math.log(0.1) + 0.5 * (2.0 / 0.1) ** 2 + 0.5 * math.log(2 * math.pi)]
    assert torch.allclose(gaussian_nll(x, mu, sigma), torch.tensor(expect), atol=1e-5)
    # and against torch's own Gaussian
    ref = -torch.distributions.Normal(mu, sigma).log_prob(x)
    assert torch.allclose(gaussian_nll(x, mu, sigma), ref, atol=1e-5)


def test_smoothness_is_squared_second_difference():
    mean = torch.tensor([[[0.0], [1.0], [4.0], [9.0]]])  # second differences 2, 2
    assert smoothness(mean).item() == pytest.approx(4.0)
    linear = torch.arange(10.0).reshape(1, 10, 1) * 3
    assert smoothness(linear).item() == 0.0
    concave = -(torch.arange(10.0) ** 2).reshape(1, 10, 1)  # signed Eq. 8 would be negative
    assert smoothness(concave).item() > 0


def test_loss_combines_terms_with_paper_weights():
    cfg = small_cfg()
    m = net(cfg)
    x, skel, traj, types = inputs(cfg)
    out = m(x, skel, traj, types)
    tx = torch.cat([torch.randn(2, 90, cfg.n_continuous), (torch.rand(2, 90, 2) > 0.5).float()], -1)
    parts = ccnet_loss(out, tx, traj, cfg.n_continuous)
    total = parts["nll"] + 10 * parts["smooth"] + 2 * parts["contact"] + parts["traj_nll"]
    assert torch.allclose(parts["loss"], total)
    assert sigma_min_respected(out, cfg)


def test_loss_leaves_out_constant_channels():
    """``channels`` drops channels from L_G and L_s: by hand on two channels, one left out."""
    target = torch.tensor([[[1.0, 0.0, 1.0]]]).repeat(1, 3, 1)   # (1, 3, 2 continuous + 1 contact)
    mean = torch.tensor([[[0.0, 5.0], [0.0, -5.0], [0.0, 5.0]]])
    out = dict(mean=mean, sigma=torch.tensor([[[1.0, 1e-4]]]).repeat(1, 3, 1),
               contact_logits=torch.zeros(1, 3, 1), traj_mean=torch.zeros(1, 3, 1), traj_sigma=torch.ones(1, 3, 1))
    keep = torch.tensor([True, False])
    parts = ccnet_loss(out, target, torch.zeros(1, 3, 1), 2, channels=keep)
    assert parts["nll"].item() == pytest.approx(0.5 + 0.5 * math.log(2 * math.pi), abs=1e-6)
    assert parts["smooth"].item() == 0.0                        # channel 0's mean is constant
    assert ccnet_loss(out, target, torch.zeros(1, 3, 1), 2)["smooth"].item() == pytest.approx(20.0 ** 2 / 2)


def test_normaliser_marks_the_constant_channels():
    x = np.array([[1.0, 2.0, 3.0, 0.0], [1.0, 5.0, 3.0, 1.0]])   # channels 0 and 2 constant (last: a contact)
    norm = Normaliser.fit(x, np.ones((2, 1)), np.ones((2, 1)), n_continuous=3)
    np.testing.assert_array_equal(norm.constant_channels(), [True, False, True])
    assert not norm.norm_x(x)[:, :3][:, norm.constant_channels()].any()


def sigma_min_respected(out, cfg):
    return bool((out["sigma"] >= cfg.sigma_min).all() and (out["traj_sigma"] >= cfg.sigma_min).all())


def test_checkpoint_roundtrip_reproduces_outputs_exactly(tmp_path):
    cfg = small_cfg((1, 2, 4))
    m = net(cfg, seed=3)
    norm = Normaliser(*(np.random.default_rng(0).normal(size=n).astype(np.float32) for n in (28, 28, 7, 7, 12, 12)))
    path = save_checkpoint(tmp_path / "c.safetensors", m, norm, {"step": "5", "note": {"a": 1}})
    m2, norm2, meta = load_checkpoint(path)
    assert m2.cfg == cfg and meta["step"] == 5 and meta["note"] == {"a": 1}
    x, skel, traj, types = inputs(cfg)
    assert torch.equal(outputs(m, x, skel, traj, types), outputs(m2, x, skel, traj, types))
    assert all(np.array_equal(getattr(norm, k), getattr(norm2, k)) for k in norm.__dataclass_fields__)
    assert not list(tmp_path.glob("*.tmp"))  # atomic write left no temporary file


def test_config_json_roundtrip_and_validation():
    cfg = small_cfg((1, 2, 4))
    assert CCNetConfig.from_json(cfg.to_json()) == cfg
    with pytest.raises(ValueError):
        CCNetConfig(kernel_size=3)


def latent_net(**kw):
    cfg = small_cfg(latent=4, posterior_hidden=16, **kw)
    m = net(cfg)
    with torch.no_grad():  # a z that visibly moves the output
        m.z_in.weight.mul_(10)
    return cfg, m


@pytest.mark.parametrize("without_z, z_scale", [((), 1.0), (("traj",), 1.0), (("traj",), 0.0),
                                                (("traj", "root"), 1.0), (("root",), 1.0)])
@pytest.mark.parametrize("backend", ["torch", "numpy"])
def test_latent_incremental_equals_full_recompute(backend, without_z, z_scale):
    """With a latent, the stepper given the same z per frame equals the full forward (also when
    the predicted c^d or the root does not see z, where the steppers skip the second decode for z = 0)."""
    cfg, m = latent_net(traj_without_z="traj" in without_z, root_without_z="root" in without_z)
    x, skel, traj, types = inputs(cfg, b=2, t=50)
    z = z_scale * torch.randn(2, 50, cfg.latent, generator=torch.Generator().manual_seed(3))
    with torch.no_grad():
        full = m.head(m.trunk(x, skel, traj, types), z, traj)  # the raw output: mean, sigma, contacts, c^d
        zero = m(x, skel, traj, types)["mean"]
    assert torch.allclose(stepped(m, backend, x, skel, traj, types, z), full, atol=1e-4)
    assert torch.allclose(full[..., :cfg.n_continuous], zero, atol=1e-2) == (z_scale == 0)  # z matters


def test_traj_without_z_plans_from_the_past_alone():
    """traj_without_z: the predicted c^d is the same whatever z; the frame's mean is not."""
    cfg, m = latent_net(traj_without_z=True)
    x, skel, traj, types = inputs(cfg, t=20)
    z = torch.randn(2, 20, cfg.latent)
    with torch.no_grad():
        a, b = m(x, skel, traj, types, z=z), m(x, skel, traj, types, z=-z)
    torch.testing.assert_close(a["traj_mean"], b["traj_mean"])
    torch.testing.assert_close(a["traj_sigma"], b["traj_sigma"])
    assert not torch.allclose(a["mean"], b["mean"], atol=1e-3)


def test_root_without_z_decodes_the_root_from_the_past_alone():
    """root_without_z: the root block's mean and sigma (the last 4 continuous channels) are the
    same whatever z; the rest of the frame's mean is not; the predicted c^d still sees z."""
    cfg, m = latent_net(root_without_z=True)
    np.testing.assert_array_equal(cfg.without_z_columns, [*range(cfg.n_continuous - 4, cfg.n_continuous),
                                                          *range(2 * cfg.n_continuous - 4, 2 * cfg.n_continuous)])
    both = replace(cfg, traj_without_z=True).without_z_columns
    assert list(both[8:]) == list(range(cfg.output_slices["traj_mean"].start, cfg.n_out))
    x, skel, traj, types = inputs(cfg, t=20)
    z = torch.randn(2, 20, cfg.latent)
    with torch.no_grad():
        a, b = m(x, skel, traj, types, z=z), m(x, skel, traj, types, z=-z)
    root = slice(cfg.n_continuous - 4, cfg.n_continuous)
    torch.testing.assert_close(a["mean"][..., root], b["mean"][..., root])
    torch.testing.assert_close(a["sigma"][..., root], b["sigma"][..., root])
    assert not torch.allclose(a["mean"][..., :root.start], b["mean"][..., :root.start], atol=1e-3)
    assert not torch.allclose(a["traj_mean"], b["traj_mean"], atol=1e-3)


def test_latent_posterior_sample_in_training_mean_in_eval():
    cfg, m = latent_net()
    x, skel, traj, types = inputs(cfg, t=20)
    target = torch.randn_like(x)
    with torch.no_grad():
        ev = m(x, skel, traj, types, target_x=target)
        z_mean = ev["z_mean"]
        by_z = m(x, skel, traj, types, z=z_mean)["mean"]
        m.train()
        m.dropout.p = 0.0
        tr = m(x, skel, traj, types, target_x=target)
    assert ev["z_logvar"].shape == z_mean.shape == (2, 20, cfg.latent)
    assert torch.allclose(ev["mean"], by_z, atol=1e-6)          # eval: z is the posterior mean
    assert not torch.allclose(tr["mean"], ev["mean"], atol=1e-3)  # training: a sample
    assert "z_mean" not in m(x, skel, traj, types)                 # no target: z = 0, no posterior
    assert not ev["prior_mean"].any() and not ev["prior_logvar"].any()  # N(0, I)


def knot_and_frame_posteriors(t: int, **kw):
    """A latent net with knots (``kw``), the same weights with a z per frame, random inputs and
    targets of ``t`` frames, and both nets' eval outputs on them."""
    cfg, m = latent_net(**kw)
    _, per_frame = latent_net()
    per_frame.load_state_dict(m.state_dict())
    x, skel, traj, types = inputs(cfg, t=t)
    target = torch.randn_like(x)
    with torch.no_grad():
        return (cfg, m, (x, skel, traj, types), target, m(x, skel, traj, types, target_x=target),
                per_frame(x, skel, traj, types, target_x=target))


def test_held_latent_is_one_z_per_block_with_one_kl_per_block():
    """latent_hold k: the posterior's mean and log-variance are averaged over each block of k
    frames (the last may be shorter), the decoder sees that block's z on each of its frames, and
    the KL counts each z once, per frame of the window."""
    from mocapviz.training.losses import gaussian_kl
    cfg, m, (x, skel, traj, types), target, ev, frames = knot_and_frame_posteriors(20, latent_hold=3)
    with torch.no_grad():
        by_z = m(x, skel, traj, types, z=ev["z_mean"].repeat_interleave(3, 1)[:, :20])["mean"]
    assert ev["z_mean"].shape == (2, 7, cfg.latent)                      # ceil(20 / 3) blocks
    torch.testing.assert_close(ev["z_mean"][:, 1], frames["z_mean"][:, 3:6].mean(1))
    torch.testing.assert_close(ev["z_logvar"][:, 6], frames["z_logvar"][:, 18:].mean(1))
    torch.testing.assert_close(ev["mean"], by_z)
    out = dict(ev, sigma=torch.ones_like(ev["mean"]), traj_sigma=torch.ones_like(ev["traj_mean"]))
    kl = ccnet_loss(out, target, torch.zeros_like(ev["traj_mean"]), cfg.n_continuous)["kl"]
    blocks = gaussian_kl(ev["z_mean"], ev["z_logvar"], 0.0 * ev["z_mean"], 0.0 * ev["z_mean"]).sum((1, 2))
    assert kl.item() == pytest.approx(blocks.mean().item() / 20, rel=1e-5)


def test_latent_weights_hand_computed():
    held = [[1, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1]]
    np.testing.assert_array_equal(latent_weights(5, 2), held)
    blended = [[1, 0, 0], [.5, .5, 0], [0, 1, 0], [0, .5, .5], [0, 0, 1]]
    np.testing.assert_array_equal(latent_weights(5, 2, lerp=True), blended)
    np.testing.assert_array_equal(latent_weights(6, 2, lerp=True)[-1], [0, 0, .5, .5])  # a knot past the end
    np.testing.assert_array_equal(latent_weights(4, 1, lerp=True), np.eye(4))


def test_blended_latent_pools_the_posterior_with_the_hat_weights():
    """latent_lerp: a knot's posterior is the hat-weighted mean of the frames' posteriors, and the
    decoder sees the linear blend of the knots."""
    cfg, m, (x, skel, traj, types), target, ev, frames = knot_and_frame_posteriors(10, latent_hold=4, latent_lerp=True)
    zk, zf = ev["z_mean"], frames["z_mean"]
    assert zk.shape == (2, 4, cfg.latent)                                # knots at frames 0, 4, 8, 12
    torch.testing.assert_close(zk[:, 1], (zf[:, 1:8] * torch.tensor([.25, .5, .75, 1, .75, .5, .25])[:, None]).sum(1) / 4)
    torch.testing.assert_close(zk[:, 2], (zf[:, 5:10] * torch.tensor([.25, .5, .75, 1, .75])[:, None]).sum(1) / 3.25)  # frames 5-9
    blend = torch.stack([zk[:, t // 4] * (1 - (t % 4) / 4) + zk[:, t // 4 + 1] * ((t % 4) / 4) for t in range(10)], 1)
    with torch.no_grad():
        torch.testing.assert_close(ev["mean"], m(x, skel, traj, types, z=blend)["mean"])


def test_knots_are_drawn_where_generation_draws_them():
    """Knot j is drawn at its block's first frame (held), or k frames before the knot when
    blended (z starts moving towards it then; knots 0 and 1 both at frame 0); the mean output
    (no z given) decodes the blend of the knots' prior means."""
    from mocapviz.models.ccnet_extensions import knot_prior_frames
    np.testing.assert_array_equal(knot_prior_frames(10, 4), [0, 4, 8])
    np.testing.assert_array_equal(knot_prior_frames(10, 4, lerp=True), [0, 0, 4, 8])
    np.testing.assert_array_equal(knot_prior_frames(5, 1, lerp=True), [0, 0, 1, 2, 3])  # drawn a frame ahead
    cfg, m = latent_net(latent_hold=4, latent_lerp=True)
    x, skel, traj, types = inputs(cfg, t=10)
    with torch.no_grad():
        skip = m.trunk(x, skel, traj, types)
        ev = m(x, skel, traj, types, target_x=torch.randn_like(x))
        prior = m.prior_of(skip[:, [0, 0, 4, 8]])
        torch.testing.assert_close(ev["prior_mean"], prior[0])
        torch.testing.assert_close(ev["prior_logvar"], prior[1])
        blend = torch.einsum("tj,bjl->btl", torch.from_numpy(latent_weights(10, 4, lerp=True)), prior[0])
        torch.testing.assert_close(m(x, skel, traj, types)["mean"], m(x, skel, traj, types, z=blend)["mean"])


def test_gaussian_kl_hand_computed():
    from mocapviz.training.losses import gaussian_kl
    mean = torch.tensor([0.0, 1.0, 0.0, 0.0])
    logvar = torch.tensor([0.0, 0.0, math.log(4.0), 0.0])
    prior_mean = torch.tensor([0.0, 0.0, 0.0, 2.0])
    prior_logvar = torch.tensor([0.0, 0.0, 0.0, math.log(4.0)])
    want = torch.tensor([0.0, 0.5, 0.5 * (4.0 - 1.0 - math.log(4.0)), 0.5 * (math.log(4.0) + 0.25)])
    assert torch.allclose(gaussian_kl(mean, logvar, prior_mean, prior_logvar), want, atol=1e-6)


def test_latent_loss_adds_the_weighted_kl():
    cfg, m = latent_net()
    x, skel, traj, types = inputs(cfg, t=20)
    target = torch.randn_like(x)
    target[..., cfg.n_continuous:] = (target[..., cfg.n_continuous:] > 0).float()
    with torch.no_grad():
        out = m(x, skel, traj, types, target_x=target)
    tt = torch.randn(2, 20, cfg.n_traj)
    a = ccnet_loss(out, target, tt, cfg.n_continuous, kl_weight=0.0)
    b = ccnet_loss(out, target, tt, cfg.n_continuous, kl_weight=0.5)
    kl = (0.5 * (out["z_mean"] ** 2 + out["z_logvar"].exp() - 1 - out["z_logvar"])).sum(-1).mean()  # N(0, I) prior
    assert torch.allclose(b["kl"], kl) and float(kl) > 0
    assert torch.allclose(b["loss"] - a["loss"], 0.5 * kl, atol=1e-6 * float(a["loss"].abs()))


def test_latent_rollout_steps_with_the_posterior_mean():
    """A latent model's rolled-out frame is the full forward's mean on the rolled-out inputs,
    with z the posterior mean given the true next frame."""
    from mocapviz.training.trainer import rolled_out
    cfg, m = latent_net(residual=True)
    x, skel, traj, types = inputs(cfg, t=12)
    target = torch.randn_like(x)
    b = dict(x=x, skel=skel, traj=traj, types=types, target_x=target,
             varying=torch.ones(cfg.n_continuous, dtype=torch.bool))
    rolled = rolled_out(m, b, start=5)
    with torch.no_grad():
        mean = m(rolled, skel, traj, types, target_x=target)["mean"]
        prior = m(rolled, skel, traj, types)["mean"]
    n = cfg.n_continuous
    assert torch.equal(rolled[:, :5], x[:, :5])
    assert torch.allclose(rolled[:, 5:, :n], mean[:, 4:-1], atol=1e-4)
    assert not torch.allclose(rolled[:, 5:, :n], prior[:, 4:-1], atol=1e-3)


def test_unguided_rollout_steps_with_the_priors_mean():
    """``guided=False`` (the drift table's free run): z is the prior's mean, as in generation."""
    from mocapviz.training.trainer import rolled_out
    cfg, m = latent_net()
    x, skel, traj, types = inputs(cfg, t=12)
    b = dict(x=x, skel=skel, traj=traj, types=types, target_x=torch.randn_like(x),
             varying=torch.ones(cfg.n_continuous, dtype=torch.bool))
    rolled = rolled_out(m, b, start=5, guided=False)
    with torch.no_grad():
        mean = m(rolled, skel, traj, types)["mean"]
    assert torch.allclose(rolled[:, 5:, :cfg.n_continuous], mean[:, 4:-1], atol=1e-4)

