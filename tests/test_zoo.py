"""The model zoo's names: models named by role, old names still loading with a warning."""

from __future__ import annotations

import pytest
import torch

from data_prep import zoo as repo_zoo
from mocapviz import zoo


@pytest.mark.parametrize("old, new", sorted(zoo.RENAMED.items()))
def test_an_old_name_loads_the_renamed_model_with_a_warning(old, new):
    with pytest.warns(DeprecationWarning, match=new):
        model, norm, meta = repo_zoo.load(old, retrain_if_missing=False)
    ref, ref_norm, ref_meta = repo_zoo.load(new, retrain_if_missing=False)
    assert model.state_dict().keys() == ref.state_dict().keys()
    assert all(torch.equal(v, ref.state_dict()[k]) for k, v in model.state_dict().items())
    assert meta == ref_meta
    with pytest.warns(DeprecationWarning, match=new):
        assert zoo.find_checkpoint(old, cwd=repo_zoo.ZOO_DIR).samefile(zoo.find_checkpoint(new, cwd=repo_zoo.ZOO_DIR))
    with pytest.warns(DeprecationWarning, match=new):
        assert repo_zoo.committed_path(old) == repo_zoo.committed_path(new)


def test_every_role_name_has_its_config():
    assert zoo.RECIPES["ccnet_generate"][0] == "generate" and zoo.RECIPES["ccnet_paper"][0] == "paper_next_frame"
    assert set(zoo.RENAMED.values()) <= set(zoo.MODELS) and not set(zoo.RENAMED) & set(zoo.MODELS)
    assert zoo.MODELS["erd_quick"].checkpoint_every == zoo.MODELS["erd_quick"].eval_every == 1200


def test_a_missing_model_is_never_trained_by_surprise(tmp_path):
    """No committed file: one error (a FileNotFoundError) naming the command that trains it and
    the models that have a file; nothing is trained and no data is built."""
    (tmp_path / "ccnet_default.safetensors").write_bytes(b"")
    (tmp_path / "ccnet_generate.part1.safetensors").write_bytes(b"")  # a part is not a model
    with pytest.raises(zoo.ModelNotFound) as e:
        zoo.load("ccnet_generate", zoo_dir=tmp_path)
    msg = str(e.value)
    assert isinstance(e.value, FileNotFoundError)
    assert "python -m data_prep train --config generate " in msg
    assert "--export models/zoo/ccnet_generate.safetensors" in msg
    assert "models with a file in" in msg and msg.endswith("ccnet_default")
    # handed a cache and data, it looks for a cached run but trains none
    with pytest.raises(zoo.ModelNotFound, match="no cached run.*--config generate "):
        zoo.load("ccnet_generate", zoo_dir=tmp_path, cache_dir=tmp_path / "runs",
                 dataset=lambda: pytest.fail("built the data"))
    assert not (tmp_path / "runs").exists()
    with pytest.raises(zoo.ModelNotFound, match="--config quick --model erd --steps 1200 --eval-every 1200"):
        zoo.load("erd_quick", zoo_dir=tmp_path)
    with pytest.raises(FileNotFoundError, match="unknown model 'ccnet_generat'.*ccnet_default"):
        zoo.load("ccnet_generat", zoo_dir=tmp_path)  # a typo


def test_repository_load_defaults_to_no_training(monkeypatch):
    import inspect

    assert inspect.signature(repo_zoo.load).parameters["retrain_if_missing"].default is False
    assert inspect.signature(zoo.load).parameters["retrain_if_missing"].default is False
    monkeypatch.setattr(zoo, "train", lambda *a, **k: pytest.fail("trained"))
    with pytest.raises(zoo.ModelNotFound, match="--config paper_gpu "):
        repo_zoo.load("ccnet_paper_gpu")


def _has_history_tag() -> bool:
    import subprocess
    return subprocess.run(["git", "-C", str(repo_zoo.REPO_ROOT), "rev-parse", "-q", "--verify",
                           f"refs/tags/{repo_zoo.HISTORY_TAG}"], capture_output=True).returncode == 0


def test_retired_models_left_the_zoo_and_still_load_from_the_tag():
    for name in repo_zoo.RETIRED:
        assert not repo_zoo.committed_path(name).exists() and not list(repo_zoo.ZOO_DIR.glob(f"{name}.*"))
    if not _has_history_tag():
        pytest.skip(f"no tag {repo_zoo.HISTORY_TAG} in this clone")
    with pytest.warns(UserWarning, match="retired"):
        model, norm, meta = repo_zoo.load("ccnet_wide")
    assert model.cfg.channels == 96 and meta["step"] == 2800 and len(meta["parts"]) == 2


def test_cvae4d_epochs_reads_what_the_run_did_not_what_it_was_configured_for():
    import pandas as pd

    from mocapviz.zoo import cvae4d_epochs, find_checkpoint, load_cvae4d
    for name in ("cvae4d_phase1", "cvae4d_phase2"):
        run, kept = cvae4d_epochs(name)
        configured = load_cvae4d(name)[1]["train_config"]["epochs"]
        log = pd.read_csv(find_checkpoint(name).with_name(f"{name}_losses.csv"))
        assert 1 <= kept <= run <= configured
        assert run == int(log["epoch"].max()) and kept == int(log["kept_epoch"].dropna().iloc[-1])
        evaluated = log.dropna(subset=["val_score"])  # the best validation epoch was kept, not the last as such
        assert kept == int(evaluated.loc[evaluated["val_score"].idxmin(), "epoch"])

