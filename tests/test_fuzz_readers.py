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

pytestmark = pytest.mark.skipif(DATA_DIR is None or not (CMU_FILES and HDM05_FILES and H36M_FILES),
                                reason=NO_DATA_REASON)
SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

TOKENS = ["{", "}", "ROOT", "JOINT x", "End Site", "OFFSET", "CHANNELS 3", "CHANNELS 6 Xposition",
          "Xrotation", "MOTION", "Frames: 3", "Frames: -1", "Frame Time: 0", "nan", "inf", "1e999",
          "-", "+", ".", "1_0", "0x1F", "root", "lfemur", "lhand 1 2", "0", "7", ":DEGREES", ":RADIANS",
          "# c", "\t", "\r\n", "\n", "\r", ",", ",,", "begin", "end", "dof rx ry", "axis 0 0 0 ZZZ",
          "length", "\xe9", "\x00", "1.2.3", "--1"]


def _short_bvh() -> str:
    text = CMU_FILES[0].read_text()
    head, _, body = text.partition("Frame Time:")
    ft, *frames = body.split("\n")
    head = head.replace(head[head.index("Frames:"):].split("\n")[0], "Frames: 4")
    return head + "Frame Time:" + ft + "\n" + "\n".join(frames[:4]) + "\n"


def _short_amc() -> str:
    lines = HDM05_FILES[0].read_bytes().decode("latin-1").split("\n")
    third = [i for i, line in enumerate(lines) if line.strip() == "4"][0]
    return "\n".join(lines[:third]) + "\n"


def _asf_path():
    return HDM05_FILES[0].parent / f"HDM_{HDM05_FILES[0].parent.name}.asf"


BASES = {}
if not pytestmark.args[0]:
    BASES = {"bvh": _short_bvh(), "amc": _short_amc(), "asf": _asf_path().read_text(encoding="latin-1"),
             "h36m": "\n".join(H36M_FILES[0].read_text().split("\n")[:3]) + "\n"}


@st.composite
def mutated(draw, kind):
    text = BASES[kind]
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["flip", "delete_line", "duplicate_line", "truncate", "insert"]))
        if not text:
            break
        if op == "flip":
            i = draw(st.integers(0, len(text) - 1))
            text = text[:i] + chr(draw(st.integers(0, 255))) + text[i + 1:]
        elif op in ("delete_line", "duplicate_line"):
            lines = text.split("\n")
            k = draw(st.integers(0, len(lines) - 1))
            lines[k:k + 1] = [] if op == "delete_line" else [lines[k], lines[k]]
            text = "\n".join(lines)
        elif op == "truncate":
            text = text[:draw(st.integers(0, len(text)))]
        else:
            i = draw(st.integers(0, len(text)))
            sep = draw(st.sampled_from([" ", "\n", ""]))
            text = text[:i] + sep + draw(st.sampled_from(TOKENS)) + sep + text[i:]
    return text


def _accept(fn, *args, **kw):
    try:
        fn(*args, **kw)
    except MocapFormatError as err:
        assert err.path is not None and err.path in str(err)


def test_bases_read_cleanly():
    read_bvh("base.bvh", text=BASES["bvh"])
    asf = read_asf("base.asf", text=BASES["asf"])
    assert read_amc("base.amc", asf, text=BASES["amc"]).n_frames == 3
    assert read_h36m("base.txt", text=BASES["h36m"]).n_frames == 3


@SETTINGS
@given(text=mutated("bvh") if BASES else st.just(""))
def test_fuzz_bvh(text):
    _accept(read_bvh, "fuzz.bvh", text=text)


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
