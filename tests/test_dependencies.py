"""The design card's tools (scikit-learn, JupyterLab) are dependencies in both pyproject.toml and
environment.yml, with the same version spec (test_packaging checks every conda entry's spec)."""

import yaml
from test_packaging import ROOT, _name_and_spec, _pyproject_requirements


def test_design_card_dependencies_in_both_files():
    conda = dict(_name_and_spec(d) for d in yaml.safe_load((ROOT / "environment.yml").read_text())["dependencies"]
                 if isinstance(d, str))
    py = _pyproject_requirements()
    for name in ("scikit-learn", "jupyterlab"):
        assert name in py and name in conda, name
        assert py[name] == conda[name], name
