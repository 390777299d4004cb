"""The CCNet baselines (ERD-4LR, DAE-LSTM, PFNN): shapes, causality, stepper = full forward,
PFNN's Catmull-Rom blend and phase, DAE pretraining, configs and the committed checkpoints."""

import math

import numpy as np
import pytest
import torch

from mocapviz.models.dae_lstm import DAELSTM, DAELSTMConfig
from mocapviz.models.erd import ERD, ERDConfig
from mocapviz.models.pfnn import (
    PFNN,
    PFNNConfig,
    PhaseLinear,
    catmull_rom_coefficients,
    track_phase,
)
from mocapviz.models.protocol import build_model, model_class

SMALL = dict(n_x=30, n_skel=7, n_traj=12, n_types=3)
MODELS = [ERD(ERDConfig(**SMALL, encoder=16, hidden=12, decoder=16)),
          DAELSTM(DAELSTMConfig(**SMALL, dae_hidden=16, code=6, hidden=12)),
          PFNN(PFNNConfig(**SMALL, hidden=16))]


def inputs(cfg, b=2, t=70, seed=0):
    g = torch.Generator().manual_seed(seed)
    x = torch.randn(b, t, cfg.n_x, generator=g)
    # contacts: feet alternating every 9-15 frames, so that PFNN's phase moves
    steps = torch.arange(t)[None] // torch.tensor([[9], [15]])[:b]
    x[..., -2] = (steps % 2 == 0).float()
    x[..., -1] = (steps % 2 == 1).float()
    skel = torch.randn(b, cfg.n_skel, generator=g)
    traj = torch.randn(b, t, cfg.n_traj, generator=g)
    types = torch.zeros(b, cfg.n_types)
    types[:, 1] = 1
    return x, skel, traj, types


@pytest.mark.parametrize("m", MODELS, ids=lambda m: m.name)
def test_output_shapes_and_registry(m):
    cfg = m.cfg
    x, skel, traj, types = inputs(cfg)
    out = m.eval()(x, skel, traj, types)
    n = cfg.n_x - cfg.n_contact
    assert {k: tuple(v.shape) for k, v in out.items()} == dict(
        mean=(2, 70, n), sigma=(2, 70, n), contact_logits=(2, 70, 2), traj_mean=(2, 70, 12), traj_sigma=(2, 70, 12))
    assert model_class(m.name) is type(m)
    assert type(m.cfg).from_json(m.cfg.to_json()) == m.cfg
    rebuilt = build_model(m.name, m.cfg.to_json())
    rebuilt.load_state_dict(m.state_dict())
    assert torch.equal(rebuilt.eval()(x, skel, traj, types)["mean"], out["mean"])


@pytest.mark.parametrize("m", MODELS, ids=lambda m: m.name)
def test_causal_and_skeleton_reaches_the_output(m):
    m.eval()
    x, skel, traj, types = inputs(m.cfg)
    with torch.no_grad():
        base = m(x, skel, traj, types)["mean"]
        x2 = x.clone()
        x2[:, 40] += 1.0
        moved = m(x2, skel, traj, types)["mean"]
        other_body = m(x, skel + 1.0, traj, types)["mean"]
    assert torch.equal(moved[:, :40], base[:, :40])
    # same computation otherwise: any difference is the input's (small: 4 random LSTM layers damp)
    assert (moved[:, 40] - base[:, 40]).abs().max() > 1e-6
    assert (other_body[:, 0] - base[:, 0]).abs().max() > 1e-6   # c^s enters at the first layer


@pytest.mark.parametrize("backend", ["torch", "numpy"])
@pytest.mark.parametrize("m", MODELS, ids=lambda m: m.name)
def test_stepper_equals_full_forward(m, backend):
    m.eval()
    x, skel, traj, types = inputs(m.cfg)
    with torch.no_grad():
        full = m(x, skel, traj, types)
    st = m.stepper(2, backend)
    conv = (lambda a: a.numpy()) if backend == "numpy" else (lambda a: a)
    st.set_static(conv(skel), conv(types))
    raw = [torch.as_tensor(st.step(conv(x[:, t]), conv(traj[:, t]))) for t in range(x.shape[1])]
    steps = m.split_output(torch.stack(raw, 1))
    for k in full:
        assert torch.allclose(steps[k], full[k], atol=1e-5), k
    st.reset()   # a reset stepper starts over
    st.set_static(conv(skel), conv(types))
    assert torch.allclose(torch.as_tensor(st.step(conv(x[:, 0]), conv(traj[:, 0]))), torch.stack(raw, 1)[:, 0])


def test_catmull_rom_blend_hand_computed():
    layer = PhaseLinear(1, 1)
    with torch.no_grad():
        layer.weight.copy_(torch.tensor([1.0, 2.0, 4.0, 8.0]).view(4, 1, 1))
        layer.bias.zero_()
    one = torch.ones(1, 1)

    def at(phase):
        return float(layer(one, catmull_rom_coefficients(torch.tensor([phase]))).detach())

    # halfway between sets 1 and 2: (-1/16, 9/16, 9/16, -1/16) on sets 0..3
    assert at(2 * math.pi * 1.5 / 4) == pytest.approx(-1 / 16 + 9 / 16 * 2 + 9 / 16 * 4 - 8 / 16)
    # a quarter past set 3, wrapping: w = 1/4 on sets (2, 3, 0, 1) with (-9/128, 111/128, 29/128, -3/128)
    assert at(2 * math.pi * 3.25 / 4) == pytest.approx(-9 / 128 * 4 + 111 / 128 * 8 + 29 / 128 * 1 - 3 / 128 * 2)
    for k, w in enumerate([1.0, 2.0, 4.0, 8.0]):   # at a control point the blend is that set
        assert at(2 * math.pi * k / 4) == pytest.approx(w)
    coef = catmull_rom_coefficients(torch.linspace(0, 2 * math.pi, 50))
    assert torch.allclose(coef.sum(1), torch.ones(50))


def test_phase_from_foot_contacts_on_a_real_walk(ds):
    """The causal tracker against Holden's offline labelling (linear between touchdowns, left 0,
    right pi) on a real walk, after the first gait cycle."""
    walks = ds.clips[(ds.clips.type == "walk") & (ds.clips.stop - ds.clips.start > 400)]
    r = walks.iloc[0]
    c = ds.x[r.start:r.stop, -2:] > 0.5
    phase = track_phase(torch.from_numpy(c[None].astype(np.float32)))[0][0].numpy()
    down = c[1:] & ~c[:-1]
    marks = sorted([(t + 1, 0) for t in np.flatnonzero(down[:, 0])] + [(t + 1, 1) for t in np.flatnonzero(down[:, 1])])
    assert len(marks) > 10, "a walk has touchdowns"
    t_mark = np.array([t for t, _ in marks])
    # unwrap: each touchdown is half a cycle after the previous one of the other foot
    unwrapped = np.cumsum([0.0] + [math.pi if f != g else 2 * math.pi for (_, g), (_, f) in zip(marks, marks[1:])])
    unwrapped += math.pi * marks[0][1]
    frames = np.arange(t_mark[2], t_mark[-1])
    offline = np.interp(frames, t_mark, unwrapped) % (2 * math.pi)
    err = np.angle(np.exp(1j * (phase[frames] - offline)))
    assert np.allclose(phase[t_mark], [math.pi * f for _, f in marks])  # touchdowns: left 0, right pi
    assert np.abs(err).mean() < 0.25, np.abs(err).mean()


def test_dae_pretraining_learns_to_denoise_and_is_then_frozen(ds):
    from mocapviz.training.windows import WindowData
    data = WindowData(ds, 30)
    torch.manual_seed(0)
    m = DAELSTM(DAELSTMConfig(n_types=ds.layout.n_types, pretrain_steps=150))
    losses = m.pretrain(data, seed=0)
    assert np.mean(losses[-10:]) < 0.5 * np.mean(losses[:10])
    b = data.batch(data.test[:8])
    before = {k: v.clone() for k, v in m.state_dict().items() if k.startswith("dae_")}
    out = m(**{k: b[k] for k in m.input_names})
    (out["mean"] - b["target_x"][..., :-2]).pow(2).mean().backward()
    assert all(p.grad is None for n, p in m.named_parameters() if n.startswith("dae_"))
    assert all(p.grad is not None for n, p in m.named_parameters() if n.startswith("lstm"))
    assert all(torch.equal(v, m.state_dict()[k]) for k, v in before.items())


@pytest.mark.parametrize("name", ["erd_quick", "dae_lstm_quick", "pfnn_quick"])
def test_committed_checkpoint_loads_by_name_and_learnt(name, ds):
    """Each committed baseline loads through the zoo, and its NLL of the next frame on held-out
    windows (teacher forced) is far below the same network's untrained."""
    from data_prep import zoo
    from mocapviz.training.trainer import evaluate
    from mocapviz.training.windows import WindowData
    model, norm, meta = zoo.load(name, retrain_if_missing=False)
    assert model.name == name.removesuffix("_quick") and meta["model"] == model.name
    assert meta["dataset"]["motion_types"] == list(ds.motion_types)   # dataset v4's vocabulary
    data = WindowData(ds, 60, normaliser=norm)
    torch.manual_seed(0)
    fresh = type(model)(model.cfg)
    trained_nll, fresh_nll = (evaluate(m, data, data.test[:64])["nll"] for m in (model, fresh))
    assert trained_nll < fresh_nll - 100, (trained_nll, fresh_nll)
