"""Generator(z_source="seed"): a latent model's z after the seed is the posterior's mean over the
seed's own frames, computed here independently from one full forward pass; a new motion type
drops it; a seed of one frame keeps the type's prior."""

from dataclasses import replace

import numpy as np
import pytest
import torch

from mocapviz.models.ccnet import CCNet
from mocapviz.tasks.generate import Generator
from mocapviz.training.config import TRAIN_CONFIGS

CFG = replace(TRAIN_CONFIGS["quick"], dilations=(1, 2), latent=4, latent_hold=2, latent_lerp=True)


@pytest.fixture(scope="module")
def setup(ds):
    torch.manual_seed(0)
    model = CCNet(CFG.model_config(ds.layout)).eval()
    clip = ds.clip_arrays(0)
    types = np.eye(model.cfg.n_types, dtype=np.float32)[[clip["type_index"]]]
    return model, ds.normaliser, clip, types


def test_seed_z_is_the_mean_posterior_over_the_seed(setup):
    model, norm, clip, types = setup
    s = 20
    seed_x, seed_traj = clip["x"][None, :s], clip["traj"][None, :s]
    gen = Generator(model, norm, z_source="seed")
    gen.run(seed_x, clip["skel"][None], types, 6, seed_traj=seed_traj)
    # the same from one full forward pass: input t carries x_t and c^d_{t+1}, the seed's own
    f = lambda a: torch.as_tensor(np.asarray(a, np.float32))  # noqa: E731
    x = f(norm.norm_x(seed_x))
    with torch.no_grad():
        skip = model.trunk(x[:, :-1], f(norm.norm_skel(clip["skel"][None])), f(norm.norm_traj(seed_traj[:, 1:])),
                           f(types))
        first = model.cfg.receptive_field  # frames with the whole receptive field behind them
        means = model.posterior_of(skip[:, first:], x[:, first:-1], x[:, first + 1:])[0]
    assert first < s - 1
    np.testing.assert_allclose(gen._z_seed, means.mean(1).numpy(), atol=1e-5)


def test_seed_z_changes_the_output_and_a_new_type_drops_it(setup):
    model, norm, clip, types = setup
    s, n = 20, 8
    args = (clip["x"][None, :s], clip["skel"][None])
    by_seed = Generator(model, norm, z_source="seed").run(*args, types, n, seed_traj=clip["traj"][None, :s])
    by_type = Generator(model, norm, z_source="type").run(*args, types, n, seed_traj=clip["traj"][None, :s])
    assert not np.allclose(by_seed.x[:, s:], by_type.x[:, s:])
    np.testing.assert_array_equal(by_seed.x[:, :s], by_type.x[:, :s])  # the seed is the seed
    other = (clip["type_index"] + 1) % model.cfg.n_types
    per_frame = np.repeat(types[:, None], s + n, axis=1)
    per_frame[:, s + 3:] = np.eye(model.cfg.n_types, dtype=np.float32)[other]
    gen = Generator(model, norm, z_source="seed")
    gen.run(*args, per_frame, n, seed_traj=clip["traj"][None, :s])
    assert gen._z_seed is not None and not gen._z_seed_on.any()  # the seed's z belonged to the seed's type
    # after the switch the knots are the new type's prior's: z = 0 (no type prior) decodes them
    plain = Generator(model, norm, z_source="type")
    plain.run(*args, per_frame, n, seed_traj=clip["traj"][None, :s])
    assert plain._z_past[0] is not None and np.allclose(gen._z_past[0], plain._z_past[0])


def test_a_one_frame_seed_keeps_the_type_prior(setup):
    model, norm, clip, types = setup
    gen = Generator(model, norm, z_source="seed")
    gen.run(clip["x"][None, :1], clip["skel"][None], types, 4)
    assert gen._z_seed is None
    with pytest.raises(ValueError, match="z_source"):
        Generator(model, norm, z_source="clip")
