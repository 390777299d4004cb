"""mocapviz.study.analysis on hand-made fixtures: the validity rules, the counts, and t-tests and
an ANOVA checked against the textbook formulas written here with numpy, their p-values from
mpmath's regularised incomplete beta function (independent of scipy), to 1e-9.

The fixture responses (tests/fixtures/study) are made up to exercise each rule: they are not
study results.
"""

from __future__ import annotations

from pathlib import Path

import mpmath
import numpy as np
import pandas as pd
import pytest

from mocapviz.study import analysis as an

FIXTURES = Path(__file__).parent / "fixtures" / "study"


@pytest.fixture(scope="module")
def study():
    key = an.read_key(FIXTURES / "key.json")
    return key, an.read_responses(FIXTURES / "responses")


# ---------------------------------------------------------------- responses, validity, counts
def test_validity_rules_on_the_fixture(study):
    key, responses = study
    v = an.validity(responses, key)
    assert list(v.index) == ["p1", "p2", "p3", "p4", "p5", "p6"]
    assert list(v.valid) == [True, True, True, False, False, False]
    assert v.loc["p4", "reasons"] == "under 10 min" and v.loc["p4", "minutes"] == pytest.approx(5.0)
    assert v.loc["p5", "reasons"] == "blank answers" and v.loc["p5", "blank"] == 1
    assert v.loc["p6", "reasons"] == "intransitive triads" and v.loc["p6", "triads"] == 1
    assert an.validity(responses, key, min_seconds=299).loc["p4", "valid"]  # the time rule is a parameter


def test_counts_by_hand(study):
    key, responses = study
    answers = an.answers_table(responses, key)
    assert len(answers) == 36 and answers.choice.isna().sum() == 1
    assert answers.loc[(answers.participant == "p3") & (answers.question == "q03"), "chosen_model"].item() == "dae"
    counts = an.group_counts(answers)
    # counted: ccnet in "mocap vs ccnet" and "dae vs ccnet", dae in "mocap vs dae" (read off the key by hand)
    expected = pd.DataFrame({"mocap vs ccnet": [0, 1, 2, 0, 0, 0], "dae vs ccnet": [2, 2, 2, 2, 1, 2],
                             "mocap vs dae": [0, 0, 1, 0, 0, 1]}, index=[f"p{i}" for i in range(1, 7)], dtype=float)
    pd.testing.assert_frame_equal(counts[expected.columns], expected, check_names=False)
    valid = an.group_counts(answers, ["p1", "p2", "p3"])
    assert list(valid.index) == ["p1", "p2", "p3"]


def test_responses_of_another_kit_or_twice_are_refused(study):
    key, responses = study
    with pytest.raises(ValueError, match="kit"):
        an.answers_table([dict(responses[0], kit="other")], key)
    with pytest.raises(ValueError, match="two responses"):
        an.answers_table([responses[0], responses[0]], key)
    with pytest.raises(ValueError, match="exactly"):
        an.answers_table([dict(responses[0], answers=responses[0]["answers"][:-1])], key)


@pytest.mark.parametrize("edges, triads", [
    ([("a", "b"), ("b", "c"), ("c", "a")], 1),                              # the paper's example
    ([("a", "b"), ("b", "c"), ("a", "c")], 0),                              # transitive
    ([("a", "b"), ("b", "c"), ("a", "c"), ("a", "d"), ("b", "d"), ("c", "d")], 0),  # a full order of 4
    ([("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"), ("d", "e"), ("e", "c")], 2),  # two cycles sharing c
    ([("a", "b"), ("b", "c"), ("c", "d"), ("d", "a")], 0),                  # a 4-cycle holds no triad
])
def test_intransitive_triads_by_hand(edges, triads):
    winners, losers = zip(*edges)
    assert an.intransitive_triads(winners, losers) == triads


# ---------------------------------------------------------------- statistics against formulas
# Tiny counts table: five participants, group "b" missing one (so Student / Welch see 5 vs 4).
COUNTS = pd.DataFrame({"ref": [6.0, 7.0, 5.0, 8.0, 6.0], "b": [2.0, 3.0, 1.0, np.nan, 3.0],
                       "c": [3.0, 2.0, 4.0, 2.0, 5.0]}, index=["u1", "u2", "u3", "u4", "u5"])


def _t_sf2(t: float, df: float) -> float:
    """Two-sided p of Student's t distribution: I_{df / (df + t^2)}(df / 2, 1 / 2)."""
    return float(mpmath.betainc(df / 2, 0.5, 0, df / (df + t * t), regularized=True))


def _f_sf(f: float, d1: float, d2: float) -> float:
    """Upper tail of the F distribution: I_{d2 / (d2 + d1 f)}(d2 / 2, d1 / 2)."""
    return float(mpmath.betainc(d2 / 2, d1 / 2, 0, d2 / (d2 + d1 * f), regularized=True))


def test_t_tests_match_the_formulas():
    mpmath.mp.dps = 30
    table = an.t_tests(COUNTS, "ref", ["b", "c"]).set_index(["group", "test"])
    for other in ("b", "c"):
        x, y = COUNTS[other].dropna().to_numpy(), COUNTS["ref"].to_numpy()
        n1, n2, v1, v2 = len(x), len(y), x.var(ddof=1), y.var(ddof=1)
        sp2 = ((n1 - 1) * v1 + (n2 - 1) * v2) / (n1 + n2 - 2)
        student = ((x.mean() - y.mean()) / np.sqrt(sp2 * (1 / n1 + 1 / n2)), n1 + n2 - 2)
        se2 = v1 / n1 + v2 / n2
        welch = ((x.mean() - y.mean()) / np.sqrt(se2), se2 ** 2 / ((v1 / n1) ** 2 / (n1 - 1) + (v2 / n2) ** 2 / (n2 - 1)))
        both = COUNTS[[other, "ref"]].dropna()
        d = (both[other] - both["ref"]).to_numpy()
        paired = (d.mean() / (d.std(ddof=1) / np.sqrt(len(d))), len(d) - 1)
        for test, (t, df) in (("student", student), ("welch", welch), ("paired", paired)):
            row = table.loc[(other, test)]
            assert row.t == pytest.approx(t, rel=1e-9, abs=1e-9)
            assert row.df == pytest.approx(df, rel=1e-9)
            assert row.p == pytest.approx(_t_sf2(t, df), rel=1e-9)
    assert table.loc[("b", "paired"), "n_other"] == 4 and table.loc[("b", "student"), "n_reference"] == 5


def test_anova_table_matches_the_formulas():
    mpmath.mp.dps = 30
    groups = ["ref", "b", "c"]
    table = an.anova_table(COUNTS, groups)
    samples = [COUNTS[g].dropna().to_numpy() for g in groups]
    grand = np.concatenate(samples).mean()
    ss_b = sum(len(s) * (s.mean() - grand) ** 2 for s in samples)
    ss_w = sum(((s - s.mean()) ** 2).sum() for s in samples)
    d1, d2 = len(samples) - 1, sum(map(len, samples)) - len(samples)
    f = (ss_b / d1) / (ss_w / d2)
    f_crit = float(mpmath.findroot(lambda q: mpmath.betainc(d2 / 2, d1 / 2, 0, d2 / (d2 + d1 * q), regularized=True)
                                   - mpmath.mpf("0.05"), 3.8))
    between, within, total = table["Between Groups"], table["Within Groups"], table["Total"]
    for got, want in ((between.SS, ss_b), (within.SS, ss_w), (total.SS, ss_b + ss_w), (between.MS, ss_b / d1),
                      (within.MS, ss_w / d2), (between.F, f), (between["P-value"], _f_sf(f, d1, d2)),
                      (between["F-critical"], f_crit)):
        assert got == pytest.approx(want, rel=1e-9)
    assert (between.df, within.df, total.df) == (2, 11, 13)
    assert list(table.index) == ["SS", "df", "MS", "F", "P-value", "F-critical"]
    assert np.isnan(within.F) and np.isnan(total.MS)  # "-" in the paper's layout


def test_group_means():
    t = an.group_means(COUNTS, ["ref", "b"])
    assert t.loc["b", "n"] == 4 and t.loc["b", "mean"] == 2.25
    assert t.loc["ref", "std"] == pytest.approx(np.sqrt(((COUNTS.ref - 6.4) ** 2).sum() / 4), rel=1e-12)
