"""Golden numbers: recompute each fixture of ``tests/fixtures/golden/`` from its stored inputs
(``tools/make_golden_fixtures.py``, the one place that defines them) and compare.

Tolerance 1e-6, absolute, with two stated exceptions:

- the CCNet features are float32 by design (``motion_features``) and reach 39 (angular
  velocities in rad/s), where one float32 step is 4e-6: they are compared at 1e-6 absolute
  *plus* 1e-6 relative (about 8 float32 steps), never looser;
- anny runs in float32 and its sums depend on torch's thread count (chi moved by 8.8e-7 between
  1 and 2 threads when measured), so the recomputation runs on one thread, as the script does.

If a change is intended, regenerate (``python tools/make_golden_fixtures.py NAME``) and commit
the new fixture with the change; otherwise a failure here is a regression.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import torch

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("make_golden_fixtures", ROOT / "tools" / "make_golden_fixtures.py")
golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(golden)

RTOL = {"ccnet_features_35_01": 1e-6}


@pytest.fixture
def one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def test_fixtures_are_small_and_hold_no_raw_mocap():
    files = sorted(golden.OUT_DIR.glob("*.npz"))
    assert [f.stem for f in files] == sorted(golden.FIXTURES)
    assert sum(f.stat().st_size for f in files) < 200_000
    for f in files:
        assert not {"rotations", "positions", "root_positions"} & set(np.load(f).files), f


@pytest.mark.parametrize("name", list(golden.FIXTURES))
def test_recomputed_equals_golden(name, data_dir, one_thread):
    ref = dict(np.load(golden.OUT_DIR / f"{name}.npz"))
    inputs = {k: v for k, v in ref.items() if k.startswith("in_")}
    out = golden.compute(name, inputs, data_dir)
    assert set(out) == set(ref) - set(inputs)
    for key, value in out.items():
        assert value.shape == ref[key].shape and value.dtype == ref[key].dtype, key
        np.testing.assert_allclose(value, ref[key], rtol=RTOL.get(name, 0.0), atol=1e-6, err_msg=f"{name}:{key}")
