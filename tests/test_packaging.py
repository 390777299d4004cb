"""environment.yml must agree with pyproject.toml, the source of truth for dependencies."""

import re
import tomllib
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent


def _name_and_spec(req: str) -> tuple[str, str]:
    m = re.match(r"\s*([A-Za-z0-9_.\-]+)(?:\[[^\]]*\])?\s*(.*)", req)
    return m[1].lower().replace("_", "-"), m[2].replace(" ", "")


def _pyproject_requirements() -> dict[str, str]:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    reqs = list(meta["dependencies"])
    for extra in meta["optional-dependencies"].values():
        reqs += [r for r in extra if not r.startswith("mocapviz")]
    return dict(_name_and_spec(r) for r in reqs)


def test_environment_yml_matches_pyproject():
    env = yaml.safe_load((ROOT / "environment.yml").read_text())
    py = _pyproject_requirements()
    conda = [d for d in env["dependencies"] if isinstance(d, str) and not d.startswith(("python", "pip"))]
    assert conda, "environment.yml lists no packages"
    for dep in conda:
        name, spec = _name_and_spec(dep)
        assert name in py, f"{name} is in environment.yml but not in pyproject.toml"
        assert spec == py[name], f"{name}: environment.yml says {spec!r}, pyproject says {py[name]!r}"
    pip = next(d["pip"] for d in env["dependencies"] if isinstance(d, dict))
    assert "torch==2.13.0" in pip and "-e .[dev]" in pip


def test_torch_range_admits_only_the_cpu_pin_or_older():
    spec = _pyproject_requirements()["torch"]
    assert "<=2.13.0" in spec, "an open torch range pulls a multi-GB CUDA build"
