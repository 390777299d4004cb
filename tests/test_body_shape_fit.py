"""Shape fitting lowers the segment-length error on real subjects and respects the bounds."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.bodies.anny_model import BETA_BOUNDS, BETA_LABELS, body_model
from mocapviz.bodies.shape_fit import SEGMENTS, anny_segment_lengths, fit_shapes, segment_lengths


@pytest.fixture(scope="session")
def body():
    return body_model()


@pytest.fixture(scope="session")
def skeletons(data_dir):
    from data_prep.catalog import build_catalog, load_motion
    cat = build_catalog(data_dir)
    clips = {"cmu07": "07_01", "bd": "HDM_bd_sneak2StepsLStart_001_120"}
    return {s: load_motion(cat[cat["clip"] == c].iloc[0]).skeleton for s, c in clips.items()}


def test_segment_lengths_are_bone_lengths(skeletons):
    sk = skeletons["cmu07"]
    seg = dict(zip(SEGMENTS, segment_lengths(sk)))
    assert seg["shin.L"] == pytest.approx(sk.bone_lengths()[sk.index("LeftFoot")])
    assert seg["thigh.R"] == pytest.approx(sk.bone_lengths()[sk.index("RightLeg")])


def test_fit_lowers_error_on_real_subjects(body, skeletons):
    fit = fit_shapes(body, skeletons, steps=60)
    rep = fit.report().set_index("subject")
    for s in skeletons:
        assert rep.loc[s, "err_after_cm"] < rep.loc[s, "err_before_cm"] - 0.8, rep
        assert rep.loc[s, "err_after_cm"] < 3.5
    for i, k in enumerate(BETA_LABELS):
        lo, hi = BETA_BOUNDS[k]
        assert np.all((fit.beta[:, i] >= lo) & (fit.beta[:, i] <= hi))
    # the reported errors are those of anny's skeleton at the returned betas
    np.testing.assert_allclose(anny_segment_lengths(body, fit.beta) - fit.target, fit.after, atol=1e-6)
