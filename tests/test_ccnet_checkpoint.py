"""The committed checkpoint through the model protocol: loads, bit-identical outputs, registry, zoo."""

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors import safe_open

from data_prep import zoo as repo_zoo
from mocapviz import zoo
from mocapviz.models.ccnet import CCNet
from mocapviz.models.protocol import MODELS, build_model, model_class, register_model
from mocapviz.models.steppers import CCNetStepper
from mocapviz.training.checkpoint import FORMAT, load_checkpoint, read_checkpoint, save_checkpoint

FIXTURES = Path(__file__).resolve().parent / "fixtures"
CKPT = repo_zoo.committed_path("ccnet_v3_rmsprop")  # the first committed model, pre-registry format


def _fixture_module():
    spec = importlib.util.spec_from_file_location("make_ccnet_outputs", FIXTURES / "make_ccnet_outputs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_committed_checkpoint_is_the_legacy_format_and_loads_as_ccnet():
    with safe_open(str(CKPT), framework="pt") as f:
        raw_meta = f.metadata()
    assert raw_meta["format"] == "mocapviz.ccnet.v1" and "model" not in raw_meta
    model, _, meta = load_checkpoint(CKPT)
    assert type(model) is CCNet and meta["model"] == "ccnet" and model.name == "ccnet"


def test_committed_checkpoint_gives_the_outputs_of_the_code_before_the_split():
    """Equal to ``fixtures/ccnet_default_outputs.npz``, written by the pre-registry code: bit for bit
    on the machine that wrote it, within float32 rounding (1e-5) on another CPU, whose BLAS
    kernels sum in another order (an AMD EPYC differed by 5e-7)."""
    mk = _fixture_module()
    model, _, _ = load_checkpoint(CKPT)
    t = {k: torch.from_numpy(v) for k, v in mk.inputs(model.cfg).items()}
    ref = np.load(FIXTURES / "ccnet_default_outputs.npz")
    with torch.no_grad():
        full = model(t["x"], t["skel"], t["traj"], t["types"])
    for k, v in full.items():
        np.testing.assert_allclose(v[:, -mk.KEEP:].numpy(), ref[f"full_{k}"], rtol=0, atol=1e-5, err_msg=k)
    st = model.stepper(2, "torch")
    assert isinstance(st, CCNetStepper)
    st.set_static(t["skel"], t["types"])
    with torch.inference_mode():
        raw = torch.stack([st.step(t["x"][:, i], t["traj"][:, i]) for i in range(mk.T)], 1)[:, -mk.KEEP:]
    np.testing.assert_allclose(raw.numpy(), ref["step_raw"], rtol=0, atol=1e-5)
    # split_output reads the same layout as the config's output_slices
    parts = model.split_output(raw)
    np.testing.assert_allclose(parts["mean"].numpy(), ref["full_mean"], atol=1e-5)


def test_resaved_checkpoint_is_the_new_format_with_the_model_name(tmp_path):
    model, norm, meta = load_checkpoint(CKPT)
    path = save_checkpoint(tmp_path / "c.safetensors", model, norm, meta)
    _, raw = read_checkpoint(path)
    assert raw["format"] == FORMAT and raw["model"] == "ccnet"
    assert json.loads(raw["model_config"]) == json.loads(model.cfg.to_json())
    m2, _, meta2 = load_checkpoint(path)
    assert meta2["step"] == meta["step"]
    assert all(torch.equal(v, m2.state_dict()[k]) for k, v in model.state_dict().items())


def test_registry_builds_by_name_and_refuses_unknown_or_twice():
    assert model_class("ccnet") is CCNet and MODELS["ccnet"] is CCNet
    model, _, _ = load_checkpoint(CKPT)
    rebuilt = build_model("ccnet", model.cfg.to_json())
    assert type(rebuilt) is CCNet and rebuilt.cfg == model.cfg
    with pytest.raises(KeyError, match="unknown model 'no_such_model'"):
        model_class("no_such_model")  # ("erd" is registered now)
    with pytest.raises(ValueError, match="registered twice"):
        register_model("ccnet")(type("Other", (), {}))


def test_library_zoo_needs_no_repository_paths(tmp_path):
    shutil.copy(CKPT, tmp_path / "ccnet_default.safetensors")
    model, norm, meta = zoo.load("ccnet_default", zoo_dir=tmp_path)
    ref, _, _ = load_checkpoint(CKPT)
    assert all(torch.equal(v, model.state_dict()[k]) for k, v in ref.state_dict().items())
    # no committed file and no data: it says what it needs instead of training
    with pytest.raises(FileNotFoundError, match="pass cache_dir and dataset"):
        zoo.load("ccnet_default", zoo_dir=tmp_path / "empty")
    with pytest.raises(KeyError):
        zoo.load("ccnet_huge", zoo_dir=tmp_path)
    # a dataset builder is called only when the committed file is not used
    zoo.load("ccnet_default", zoo_dir=tmp_path, cache_dir=tmp_path, dataset=lambda: pytest.fail("built the data"))


def test_split_checkpoint_reads_back_whole(tmp_path):
    from mocapviz.training.checkpoint import split_checkpoint
    model, norm, meta = load_checkpoint(CKPT)
    whole = save_checkpoint(tmp_path / "whole.safetensors", model, norm, meta)
    files = split_checkpoint(whole, tmp_path / "split.safetensors", max_bytes=2 ** 19)
    assert len(files) > 2 and all(f.stat().st_size < 2 ** 19 + 2 ** 16 for f in files)
    assert json.loads(read_checkpoint(files[0])[1]["parts"]) == [f.name for f in files[1:]]
    a, b = read_checkpoint(whole)[0], read_checkpoint(files[0])[0]
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_committed_split_model_loads_by_name_from_its_parts():
    from data_prep import zoo
    model, norm, meta = zoo.load("ccnet_generate")
    assert model.cfg.channels == 48 and meta["step"] == 3000 and meta["parts"] == ["ccnet_generate.part1.safetensors"]
    # more than its first file holds (float32)
    assert sum(p.numel() for p in model.parameters()) * 4 > zoo.committed_path("ccnet_generate").stat().st_size
