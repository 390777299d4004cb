"""Mutated real BVH/ASF/AMC/H3.6M text: a reader either succeeds or raises MocapFormatError.

Nothing else may escape (no IndexError from numpy, no ValueError from float, ...).
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import CMU_FILES, DATA_DIR, H36M_FILES, HDM05_FILES, NO_DATA_REASON
from mocapviz.errors import MocapFormatError
from mocapviz.io.asfamc import read_amc, read_asf
from mocapviz.io.bvh import read_bvh
from mocapviz.io.h36m import read_h36m
from tools.fuzz_readers import OPS, TOKENS, bases, mutate

pytestmark = pytest.mark.skipif(DATA_DIR is None or not (CMU_FILES and HDM05_FILES and H36M_FILES),
                                reason=NO_DATA_REASON)
SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

BASES = {}
if not pytestmark.args[0]:
    _ALL = bases(DATA_DIR)
    BASES = {kind: texts[0] for kind, texts in _ALL.items()} | {"bandai": _ALL["bvh"][-1]}


@st.composite
def mutated(draw, kind):
    """The mutations of tools/fuzz_readers.py (which runs 10,000 per format), drawn by hypothesis."""
    op = st.tuples(st.sampled_from(OPS), st.floats(0, 1, exclude_max=True), st.integers(0, 255),
                   st.sampled_from(TOKENS))
    return mutate(BASES[kind], draw(st.lists(op, min_size=1, max_size=3)))


def _accept(fn, *args, **kw):
    try:
        fn(*args, **kw)
    except MocapFormatError as err:
        assert err.path is not None and err.path in str(err)


def test_bases_read_cleanly():
    read_bvh("base.bvh", text=BASES["bvh"])
    assert read_bvh("bandai.bvh", text=BASES["bandai"]).n_frames == 4
    asf = read_asf("base.asf", text=BASES["asf"])
    assert read_amc("base.amc", asf, text=BASES["amc"]).n_frames == 3
    assert read_h36m("base.txt", text=BASES["h36m"]).n_frames == 3


@SETTINGS
@given(text=mutated("bvh") if BASES else st.just(""))
def test_fuzz_bvh(text):
    _accept(read_bvh, "fuzz.bvh", text=text)


@SETTINGS
@given(text=mutated("bandai") if BASES else st.just(""))
def test_fuzz_bandai_bvh(text):
    _accept(read_bvh, "fuzz.bvh", text=text, drop_static_root=True)


@SETTINGS
@given(text=mutated("amc") if BASES else st.just(""))
def test_fuzz_amc(text):
    asf = read_asf("base.asf", text=BASES["asf"])
    _accept(read_amc, "fuzz.amc", asf, text=text)


@SETTINGS
@given(text=mutated("asf") if BASES else st.just(""))
def test_fuzz_asf_then_amc(text):
    try:
        asf = read_asf("fuzz.asf", text=text)
    except MocapFormatError as err:
        assert err.path == "fuzz.asf"
        return
    _accept(asf.to_skeleton)
    _accept(read_amc, "base.amc", asf, text=BASES["amc"])


@SETTINGS
@given(text=mutated("h36m") if BASES else st.just(""))
def test_fuzz_h36m(text):
    _accept(read_h36m, "fuzz.txt", text=text)
