"""mocapviz.study.paper and .power: the paper's Tables 2-4 recomputed, GRIM/GRIMMER on hand
cases, power against published sample sizes and a simulation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mocapviz.study import paper
from mocapviz.study import power as pw

RESULTS = Path(__file__).resolve().parent.parent / "results" / "ccnet_user_study_recheck.csv"


@pytest.fixture(scope="module")
def recheck() -> pd.DataFrame:
    return paper.recheck()


def _row(df, table, row, quantity, method_start):
    hit = df[(df.table == table) & (df.row == row) & (df.quantity == quantity) & df.method.str.startswith(method_start)]
    assert len(hit) == 1, (table, row, quantity, method_start, len(hit))
    return hit.iloc[0]


def test_printed_number_intervals():
    assert paper.half_unit("6.625") == pytest.approx(5e-4) and paper.half_unit("6.1188e-13") == pytest.approx(5e-18)
    assert paper.half_unit("76.7500") == pytest.approx(5e-5)
    value, low, high = paper.span(lambda a, b: a - b, "1.5", 1)
    assert (value, low, high) == pytest.approx((0.5, 0.45, 0.55))


def test_welch_t_of_the_dae_lstm_row(recheck):
    # "near -12.7": Welch's t from the printed means and SDs with 15 and 16 participants
    r = _row(recheck, "Table 2", "DAE-LSTM", "t", "Welch, SD as ddof 1, n 15 vs 16")
    by_hand = (1.75 - 6.625) / np.sqrt(0.968 ** 2 / 15 + 1.165 ** 2 / 16)
    assert r.value == pytest.approx(by_hand, rel=1e-12) and round(r.value, 1) == -12.7
    assert r.paper == -11.9588 and not r.agrees
    student = _row(recheck, "Table 2", "ERD-4LR", "t", "Student, SD as ddof 1, n 16 vs 16")
    assert student.value == pytest.approx((2.75 - 6.625) / np.sqrt((1.199 ** 2 + 1.165 ** 2) / 16), rel=1e-12)
    assert not recheck[(recheck.table == "Table 2") & (recheck.quantity == "t")].agrees.any()


def test_printed_p_follows_from_printed_t_at_30_df(recheck):
    for row in ("ERD-4LR", "PFNN"):
        assert _row(recheck, "Table 2", row, "p", "two-sided p of the printed t, t distribution with 30").agrees
        assert _row(recheck, "Table 2", row, "df", "degrees of freedom").value == pytest.approx(30, abs=0.01)
    dae = _row(recheck, "Table 2", "DAE-LSTM", "df", "degrees of freedom").value
    assert 29.9 < dae < 30.0  # not the 29 df of 15 + 16 participants
    assert not _row(recheck, "Table 2", "DAE-LSTM", "p", "two-sided p of the printed t, t distribution with 29").agrees


def test_grim_and_grimmer_by_hand():
    assert paper.closest_mean("1.75", 15) == pytest.approx(26 / 15) and paper.closest_mean("1.75", 16) == 1.75
    # 1, 2, 3: mean 2, sample SD 1; integers with sum 6 have a sum of squares of 14, 16, ... (even)
    assert paper.closest_sd("2.00", "1.00", 3, 1) == pytest.approx(1.0)
    assert paper.closest_sd("2.00", "0.40", 3, 1) == pytest.approx(0.0)   # 2, 2, 2 is as close as it gets
    assert paper.closest_sd("2.00", "0.80", 3, 1) == pytest.approx(1.0)
    assert np.isnan(paper.closest_sd("1.75", "0.968", 15, 0))  # no 15 integers have the mean 1.75


def test_table4_between_ss_from_table2_means(recheck):
    r = _row(recheck, "Table 4", "ANOVA", "SS between", "from Table 2's means and SDs (ddof 1)")
    means = np.array([6.625, 1.75, 2.75, 2.375])
    assert r.value == pytest.approx(16 * ((means - means.mean()) ** 2).sum(), rel=1e-12)
    assert r.value == pytest.approx(233.5) and r.paper == 346.6875 and not r.agrees
    internal = recheck[(recheck.table == "Table 4") & recheck.method.str.startswith(("printed", "SS between +", "F distr"))]
    assert len(internal) == 6 and internal.agrees.all()  # the table is consistent with itself


def test_committed_recheck_csv_is_current(recheck):
    committed = pd.read_csv(RESULTS)
    assert list(committed.columns) == list(recheck.columns) and len(committed) == len(recheck)
    for col in ("table", "row", "quantity", "method"):
        assert (committed[col] == recheck[col]).all(), col
    for col in ("paper", "value", "low", "high"):
        np.testing.assert_allclose(committed[col].to_numpy(float), recheck[col].to_numpy(float), rtol=1e-9)
    as_text = {True: "True", False: "False", None: ""}  # a CSV reads booleans back as text, None as empty
    assert (committed.agrees.fillna("").astype(str) == recheck.agrees.map(as_text)).all()


@pytest.mark.parametrize("d, design, n", [(0.5, "two-sample", 64), (0.8, "two-sample", 26), (0.2, "two-sample", 394),
                                          (0.5, "one-sample", 34), (0.8, "one-sample", 15)])
def test_sample_sizes_of_the_power_tables(d, design, n):
    # 80% power, two-sided alpha 0.05: Cohen (1988) Table 2.4.1 and G*Power give these n
    assert pw.sample_size(d, 0.8, design) == n
    assert pw.power(d, n - 1, design) < 0.8 <= pw.power(d, n, design)


def test_power_against_a_simulation():
    rng = np.random.default_rng(0)
    d, n, sims = 0.7, 20, 20000
    x, y = rng.normal(d, 1, (sims, n)), rng.normal(0, 1, (sims, n))
    simulated = (stats.ttest_ind(x, y, axis=1).pvalue < 0.05).mean()
    assert pw.power(d, n) == pytest.approx(simulated, abs=3 * np.sqrt(0.25 / sims))
    one = (stats.ttest_1samp(rng.normal(0.4, 1, (sims, n)), 0, axis=1).pvalue < 0.05).mean()
    assert pw.power(0.4, n, "one-sample") == pytest.approx(one, abs=3 * np.sqrt(0.25 / sims))
    assert pw.power(0.0, n) == pytest.approx(0.05, rel=1e-9)  # no effect: the false-positive rate


def test_detectable_effect_and_huge_effects():
    d = pw.detectable_effect(16)
    assert pw.power(d, 16) == pytest.approx(0.8, abs=1e-9) and 0.9 < d < 1.1
    assert pw.power(4.5, 16) == pytest.approx(1.0) and not np.isnan(pw.power(4.5, 16))  # scipy's nct.cdf gives nan
    table = paper.power_table()
    assert table.notna().all().all() and (table["n for power 0.8"] >= 2).all()
