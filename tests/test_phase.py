"""The local motion phase (mocapviz.features.phase) and CCNet's phase input (CCNetConfig.phase)."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
import torch

from ccnet_reference import controls_used, full_recompute_outputs, step_outputs
from mocapviz.features.ccnet import FeatureLayout
from mocapviz.features.motion_types import one_hot
from mocapviz.features import phase as phase_module
from mocapviz.features.phase import (LEFT_FOOT, RIGHT_FOOT, clip_phases, dataset_fingerprint, local_phase, on_circle,
                                     pace_hz, paced_phase, phase_channels, phase_input)
from mocapviz.models.ccnet import CCNet
from mocapviz.models.ccnet_config import make_config
from mocapviz.tasks.denoising import teacher_forced
from mocapviz.tasks.generate import Generator
from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.training.config import TRAIN_CONFIGS
from mocapviz.training.trainer import train
from mocapviz.training.windows import WindowData

LAYOUT = FeatureLayout(25)


def striding(frames: int, hz: float, left_leads: bool) -> np.ndarray:
    """Frame vectors whose only motion is the feet swinging forward and back in anti-phase
    (heading-frame Z, 0.2 m), the left foot furthest forward at t = 0 when ``left_leads``."""
    x = np.zeros((frames, LAYOUT.n_x), dtype=np.float32)
    pos = x[:, LAYOUT.x_blocks["pos"]].reshape(frames, -1, 3)
    swing = 0.2 * np.cos(2 * np.pi * hz * np.arange(frames) / 60.0) * (1 if left_leads else -1)
    pos[:, LEFT_FOOT, 2], pos[:, RIGHT_FOOT, 2] = swing, -swing
    x[:, LAYOUT.x_blocks["pos"]] = pos.reshape(frames, -1)
    return x


def wrapped(a):
    return np.angle(np.exp(1j * np.asarray(a)))


@pytest.mark.parametrize("hz", [0.7, 1.0, 2.5])
@pytest.mark.parametrize("left_leads", [True, False])
def test_phase_of_a_stride_turns_at_its_rate_and_is_zero_with_the_left_foot_forward(left_leads, hz):
    x = striding(600, hz, left_leads)
    expected = 2 * np.pi * hz * np.arange(600) / 60.0 + (0.0 if left_leads else np.pi)
    # a 10 s clip: Hilbert phase; the band-pass bends the first and last 2 s (0.17-0.36 rad at 1 s)
    error = np.abs(wrapped(local_phase(x, LAYOUT) - expected))
    assert error[120:480].max() < 0.06
    # a 48-frame seed anywhere in it: the fitted sinusoid, exact at the last frame too
    for start in (0, 17, 300, 552):
        seed = slice(start, start + 48)
        assert np.abs(wrapped(local_phase(x[seed], LAYOUT) - expected[seed])).max() < 1e-4


def test_a_still_pose_has_a_constant_phase_and_short_inputs_work():
    x = np.zeros((100, LAYOUT.n_x), dtype=np.float32)
    assert np.all(local_phase(x, LAYOUT) == 0)
    for n in (1, 2, 10):  # shorter than filtfilt's padding: no filter, no crash
        assert local_phase(striding(n, 1.0, True), LAYOUT).shape == (n,)


def test_a_seed_without_a_cycle_turns_at_the_fallback_pace_and_a_striding_one_at_its_own():
    """paced_phase: a still seed (no cycle: pace 0) and one at the band's floor turn on at their
    ``fallback_hz``; a striding seed keeps its own pace whatever the fallback; no fallback (or 0)
    keeps the seed's pace."""
    seeds = np.stack([np.zeros((48, LAYOUT.n_x), np.float32), striding(48, 0.4, True), striding(48, 1.5, True)])
    out = paced_phase(seeds, LAYOUT, 148, fallback_hz=np.array([1.2, 1.0, 0.5]))
    hz = [pace_hz_of(out[b, 48:]) for b in range(3)]
    np.testing.assert_allclose(hz, [1.2, 1.0, 1.5], atol=1e-3)
    np.testing.assert_array_equal(paced_phase(seeds, LAYOUT, 148, fallback_hz=np.zeros(3)), paced_phase(seeds, LAYOUT, 148))
    np.testing.assert_allclose(pace_hz_of(paced_phase(seeds[:1], LAYOUT, 148)[0, 48:]), 0.0, atol=1e-6)
    np.testing.assert_allclose(pace_hz(striding(600, 1.5, False), LAYOUT), 1.5, atol=0.01)


def pace_hz_of(channels):
    """Cycles per second of (sin, cos) phase channels (F, 2) at 60 frames/s."""
    angle = np.arctan2(channels[:, 0], channels[:, 1])
    return float(np.median(wrapped(np.diff(angle)))) * 60 / (2 * np.pi)


def test_on_circle_and_channels():
    np.testing.assert_allclose(on_circle(np.array([[3.0, 4.0], [0.0, 0.0], [-0.1, 0.0]])),
                               [[0.6, 0.8], [0.0, 1.0], [-1.0, 0.0]])
    np.testing.assert_allclose(phase_channels(np.array([0.0, np.pi / 2])), [[0, 1], [1, 0]], atol=1e-7)


def test_real_walks_have_a_gait_rate_phase_with_the_left_foot_forward_at_zero(ds):
    rows = np.flatnonzero((ds.clips.type == "walk").values)
    phases = clip_phases(ds)
    rates, left_ahead = [], []
    for i in rows:
        r = ds.clips.iloc[i]
        if r.stop - r.start < 120:
            continue
        angle = np.arctan2(*phases[r.start:r.stop].T)
        rates.append(np.median(np.diff(np.unwrap(angle))) * 60 / (2 * np.pi))
        pos = ds.x[r.start:r.stop, LAYOUT.x_blocks["pos"]].reshape(r.stop - r.start, -1, 3)
        near_zero = np.abs(angle) < 0.3
        left_ahead.append(np.mean(pos[near_zero, LEFT_FOOT, 2] > pos[near_zero, RIGHT_FOOT, 2]))
    assert len(rates) >= 5
    # a gait cycle (two steps) takes about a second
    assert 0.6 < np.median(rates) < 1.4 and min(rates) > 0.3
    assert np.median(left_ahead) > 0.9


def test_window_data_appends_the_phase_to_the_trajectory_control(ds):
    plain, phased = WindowData(ds, 30), WindowData(ds, 30, phase=True)
    assert phased.traj.shape[1] == plain.traj.shape[1] + 2
    np.testing.assert_array_equal(phased.traj[:, :-2], plain.traj)
    np.testing.assert_array_equal(phased.traj[:, -2:].numpy(), clip_phases(ds))


def test_clip_phases_are_computed_once_per_dataset_content(ds, monkeypatch):
    """The cached phases equal a fresh computation, a second WindowData does not recompute them,
    and a dataset whose frames or clips changed gets its own."""
    rows = [int(np.flatnonzero((ds.clips.source == s).values)[0]) for s in ("hdm05", "cmu", "bandai")]
    clips = ds.clips.iloc[rows].reset_index(drop=True).copy()
    parts = [np.arange(r.start, r.stop) for r in clips.itertuples()]
    clips["stop"] = np.cumsum([len(p) for p in parts])
    clips["start"] = clips["stop"] - [len(p) for p in parts]
    idx = np.concatenate(parts)
    small = replace(ds, x=ds.x[idx], traj=ds.traj[idx], skel=ds.skel[rows], clips=clips, offsets=ds.offsets[rows])
    fresh = clip_phases(small, cache=False)
    assert dataset_fingerprint(small) not in phase_module._PHASE_CACHE
    cached = clip_phases(small)
    np.testing.assert_array_equal(cached, fresh)
    for r, part in zip(clips.itertuples(), parts):   # each clip on its own, as the big dataset's
        np.testing.assert_array_equal(cached[r.start:r.stop], phase_input(ds.x[part], ds.layout, ds.config.fps))
    cached[:] = 7.0                                   # the caller's copy, not the cache
    with monkeypatch.context() as m:                  # the second time is a look-up
        m.setattr(phase_module, "phase_input", lambda *a, **k: pytest.fail("recomputed a cached phase"))
        np.testing.assert_array_equal(clip_phases(small), fresh)
        np.testing.assert_array_equal(WindowData(small, 30, phase=True).traj[:, -2:].numpy(), fresh)
    x = small.x.copy()
    x[parts[0].size:] = x[parts[0].size:][::-1]       # the second and third clips' frames changed
    changed = replace(small, x=x)
    assert dataset_fingerprint(changed) != dataset_fingerprint(small)
    np.testing.assert_array_equal(clip_phases(changed), clip_phases(changed, cache=False))
    np.testing.assert_array_equal(clip_phases(changed)[:parts[0].size], fresh[:parts[0].size])
    assert not np.array_equal(clip_phases(changed), fresh)
    shorter = clips.copy()
    shorter.loc[0, "stop"] -= 30                      # the clips' rows changed, the frames did not
    assert dataset_fingerprint(replace(small, clips=shorter)) != dataset_fingerprint(small)


@pytest.mark.parametrize("harmonics", [0, 2])
@pytest.mark.parametrize("source", ["seed_pace", "network"])
@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_generator_feeds_the_seeds_phase_then_its_pace_or_the_networks_and_equals_full_recompute(
        ds, backend, source, harmonics):
    layout = ds.layout
    torch.manual_seed(0)
    model = CCNet(make_config("quick", n_x=layout.n_x, n_skel=layout.n_skel, n_traj=layout.n_traj + 2,
                              n_types=layout.n_types, phase=True, phase_harmonics=harmonics, dropout=0.0)).eval()
    if harmonics:  # the phase-functioned decoder starts at zero: give it weights that matter
        with torch.no_grad():
            model.phase_decoder.weight.normal_(0, 0.1)
    row = int(np.flatnonzero((ds.clips.type == "walk").values)[0])
    a = ds.clip_arrays(row)
    s = 50
    x, traj, skel, types = a["x"][None, :s], a["traj"][None, :s], a["skel"][None], one_hot([a["type_index"]], layout.n_types)
    g = Generator(model, ds.normaliser, backend=backend, phase_source=source)
    g.keep_outputs = True
    gen = g.run(x, skel, types, 80, seed_traj=traj)
    seed_angle = local_phase(x[0], layout)
    np.testing.assert_allclose(gen.phase[0, :s], phase_channels(seed_angle), atol=1e-6)
    inc, pred = step_outputs(g.raw_outputs, model.cfg)
    if source == "network":
        np.testing.assert_allclose(gen.phase[0, s:], on_circle(pred[0, s - 2:-1, -2:]), atol=1e-6)
    else:  # the seed's pace: the fitted sinusoid's step, every frame
        angle = np.unwrap(np.arctan2(*gen.phase[0].T))
        np.testing.assert_allclose(np.diff(angle[s - 1:]), np.diff(np.unwrap(seed_angle)).mean(), atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(gen.phase[0, s:], axis=-1), 1.0, atol=1e-6)
    # the frames are the ones a full forward pass over the same inputs and controls gives
    used = controls_used(gen, traj, pred, ds.normaliser, model.cfg)
    full = full_recompute_outputs(model, ds.normaliser, gen, skel, types, used)
    assert np.abs(inc - full).max() < 1e-5
    with pytest.raises(ValueError, match="phase_source"):
        Generator(model, ds.normaliser, phase_source="clock")


def test_a_phase_run_trains_a_ccnet_with_the_phase_in_its_control_and_baselines_refuse_it(ds, tmp_path):
    cfg = replace(TRAIN_CONFIGS["quick"], steps=4, batch_size=4, window=30, eval_every=4, checkpoint_every=4,
                  dilations=(1, 2, 4), phase=True)
    model, _, _ = load_checkpoint(train(ds, cfg, tmp_path, progress=False))
    assert model.cfg.phase and model.cfg.n_traj == ds.layout.n_traj + 2
    last = pd.read_csv(tmp_path / "losses.csv").iloc[-1]
    assert last.step == 4 and np.isfinite(last.val_nll) and np.isfinite(last.traj_nll)
    with pytest.raises(ValueError, match="no phase"):
        train(ds, replace(cfg, model="erd"), tmp_path / "erd", progress=False)


def test_phase_functioned_decoder_starts_as_the_plain_one_and_then_turns_with_the_phase():
    cfg = make_config("quick", n_x=LAYOUT.n_x, n_skel=LAYOUT.n_skel, n_traj=14, n_types=5, phase=True,
                      phase_harmonics=2)
    torch.manual_seed(0)
    model = CCNet(cfg).eval()
    skip = torch.randn(3, cfg.skip_channels)
    at = lambda p: torch.cat([torch.zeros(3, 12), torch.from_numpy(phase_channels(np.full(3, p)))], 1)  # noqa: E731
    plain = torch.nn.functional.linear(skip.relu(), model.decoder.weight[:, :, 0], model.decoder.bias)
    torch.testing.assert_close(model.head(skip, traj=at(0.3)), plain)
    with torch.no_grad():
        model.phase_decoder.weight.normal_(0, 0.1)
        a, b, c = (model.head(skip, traj=at(p)) for p in (0.3, 0.3 + np.pi, 0.3 + 2 * np.pi))
    assert (a - b).abs().max() > 0.1
    torch.testing.assert_close(a, c, atol=1e-5, rtol=0)   # periodic in the phase
    with pytest.raises(ValueError, match="needs phase"):
        make_config("quick", phase_harmonics=2)


def test_teacher_forcing_gives_a_phase_model_the_clips_phase(ds):
    layout, norm = ds.layout, ds.normaliser
    torch.manual_seed(0)
    model = CCNet(make_config("quick", n_x=layout.n_x, n_skel=layout.n_skel, n_traj=layout.n_traj + 2,
                              n_types=layout.n_types, phase=True, phase_harmonics=1)).eval()
    with torch.no_grad():
        model.phase_decoder.weight.normal_(0, 0.1)
    a = ds.clip_arrays(int(np.flatnonzero((ds.clips.type == "walk").values)[0]))
    types = one_hot([a["type_index"]], layout.n_types)[0]
    out = teacher_forced(model, norm.norm_x(a["x"]), norm.norm_skel(a["skel"]), norm.norm_traj(a["traj"]), types, a["x"])
    traj = np.concatenate([norm.norm_traj(a["traj"]), phase_channels(local_phase(a["x"], layout))], 1)
    f = lambda v: torch.from_numpy(np.asarray(v, np.float32))[None]  # noqa: E731
    with torch.no_grad():
        full = model(f(norm.norm_x(a["x"])[:-1]), f(norm.norm_skel(a["skel"])), f(traj[1:]), f(types))
    np.testing.assert_allclose(out["mean"], full["mean"][0].numpy(), atol=1e-6)
