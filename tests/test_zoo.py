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
