"""The CCNet paper's user-study numbers (§4.5, Tables 2-4), recomputed from what it prints.

The paper reports summary statistics only. From them we recompute:

- Table 2's t and p from its means, standard deviations and group sizes, under Student's and
  Welch's tests (a paired test needs the per-participant counts, which are not printed), with
  the SDs read as sample (ddof 1) or population (ddof 0) SDs; and the p of the printed t under
  the t distribution, which shows which degrees of freedom the paper used.
- Whether each mean and SD can come from integer counts of n participants (the GRIM and GRIMMER
  checks of Brown & Heathers 2016 and Anaya 2016: a mean of n integers is k / n; their sum of
  squares is an integer of the same parity as k).
- Table 4's between-group SS from Table 2's group means, its within-group SS from Table 2's SDs,
  and Table 4's own internal consistency (MS = SS / df, F = MS ratio, p and F-critical from F).

A printed number stands for an interval (6.625 for [6.6245, 6.6255]); every recomputed value
is given with its ``low`` and ``high`` over the corners of its inputs' intervals, and it
``agrees`` when the paper's number lies in that range widened by the paper's own rounding.
"""

from __future__ import annotations

import itertools
import math
from decimal import Decimal

import numpy as np
import pandas as pd
from scipy import stats

from mocapviz.study import power as pw

# Table 2: (mean, std) of the number of generated sequences chosen over mocap (of 16 pairs), and
# the t and p of each baseline against CCNet. Group sizes: §4.5 keeps 15 questionnaires for
# DAE-LSTM and 16 for the others.
TABLE2 = {"CCNet": ("6.625", "1.165"), "DAE-LSTM": ("1.75", "0.968"), "ERD-4LR": ("2.75", "1.199"),
          "PFNN": ("2.375", "0.992")}
TABLE2_N = {"CCNet": 16, "DAE-LSTM": 15, "ERD-4LR": 16, "PFNN": 16}
TABLE2_TP = {"DAE-LSTM": ("-11.9588", "6.1188e-13"), "ERD-4LR": ("-7.4383", "2.7365e-8"),
             "PFNN": ("-8.7165", "1.0127e-9")}
# Table 3: CCNet's count of 16 in each "baseline vs CCNet" group, "mean±std" (its caption says
# "mean and variance").
TABLE3 = {"DAE-LSTM vs. CCNet": ("12.31", "2.34"), "ERD-4LR vs. CCNet": ("11.63", "2.87"),
          "PFNN vs. CCNet": ("11.45", "1.87")}
# Table 4: one-way ANOVA over four groups of 16 (df 3 and 60).
TABLE4 = {"SS": ("346.6875", "76.7500", "423.4375"), "df": (3, 60, 63), "MS": ("115.5625", "1.2792"),
          "F": "90.3420", "P-value": "3.1855e-22", "F-critical": "2.7581"}
PAIRS_PER_GROUP = 16
CHANCE = PAIRS_PER_GROUP / 2  # expected count when participants cannot tell the two apart


# ---------------------------------------------------------------- printed numbers
def half_unit(printed: str) -> float:
    """Half a unit in the last printed digit: 0.0005 for "6.625", 5e-18 for "6.1188e-13"."""
    return 0.5 * 10.0 ** Decimal(printed).as_tuple().exponent


def span(f, *inputs) -> tuple[float, float, float]:
    """``f`` at the printed ``inputs`` (strings; numbers are exact) and its min and max over the
    corners of their rounding intervals: (value, low, high)."""
    nominal = [float(x) for x in inputs]
    ranges = [(float(x) - half_unit(x), float(x) + half_unit(x)) if isinstance(x, str) else (x, x) for x in inputs]
    corners = [f(*c) for c in itertools.product(*ranges)]
    return float(f(*nominal)), float(min(corners)), float(max(corners))


def _record(table, row, quantity, method, paper, value, low=None, high=None) -> dict:
    low, high = (value if low is None else low), (value if high is None else high)
    if paper is None:
        agrees = None
    else:
        tol = half_unit(paper) if isinstance(paper, str) else 0.0
        agrees = bool(low - tol <= float(paper) <= high + tol)
    return dict(table=table, row=row, quantity=quantity, method=method,
                paper=None if paper is None else float(paper), value=value, low=low, high=high, agrees=agrees)


# ---------------------------------------------------------------- GRIM / GRIMMER
def closest_mean(mean: str, n: int) -> float:
    """The mean of n integers (k / n) closest to the printed ``mean`` (GRIM)."""
    return round(float(mean) * n) / n


def closest_sd(mean: str, sd: str, n: int, ddof: int) -> float:
    """The SD (with ``ddof``) of n integers whose mean prints as ``mean``, closest to the
    printed ``sd`` (GRIMMER): sums k with k / n in the mean's interval, sums of squares Q of
    k's parity; nan if no integer sum fits the mean."""
    lo, hi = float(mean) - half_unit(mean), float(mean) + half_unit(mean)
    best = math.nan
    for k in range(math.ceil(lo * n), math.floor(hi * n) + 1):
        q0 = (float(sd) ** 2) * (n - ddof) + k * k / n  # the sum of squares the printed SD implies
        for q in (math.floor(q0) - 2, math.floor(q0) - 1, math.floor(q0), math.floor(q0) + 1, math.floor(q0) + 2):
            if (q - k) % 2 == 0 and q - k * k / n >= 0:
                s = math.sqrt((q - k * k / n) / (n - ddof))
                if math.isnan(best) or abs(s - float(sd)) < abs(best - float(sd)):
                    best = s
    return best


def _grim_records(table: str, rows: dict, ns: dict) -> list[dict]:
    out = []
    for row, (mean, sd) in rows.items():
        for n in sorted(set(ns[row])):
            out.append(_record(table, row, "mean", f"closest mean of {n} integer counts (GRIM)", mean,
                               closest_mean(mean, n)))
            for ddof in (1, 0):
                out.append(_record(table, row, "std", f"closest SD (ddof {ddof}) of {n} integer counts with this "
                                   "mean (GRIMMER)", sd, closest_sd(mean, sd, n, ddof)))
    return out


# ---------------------------------------------------------------- Table 2
def _t(m1, s1, n1, m2, s2, n2, equal_var: bool, ddof: int):
    """Independent-samples t and two-sided p from summary statistics (scipy); an SD printed
    with ``ddof`` 0 is turned into the sample SD that scipy expects."""
    if ddof == 0:
        s1, s2 = s1 * math.sqrt(n1 / (n1 - 1)), s2 * math.sqrt(n2 / (n2 - 1))
    res = stats.ttest_ind_from_stats(m1, s1, n1, m2, s2, n2, equal_var=equal_var)
    return float(res.statistic), float(res.pvalue)


def table2_records() -> list[dict]:
    """Table 2 recomputed: per baseline, t and p under Student / Welch, SD as ddof 1 / ddof 0, n as
    printed (15 for DAE-LSTM) / 16; the p of the printed t at df 30 and at the printed n's df;
    the df that the printed t and p imply; GRIM/GRIMMER of every mean and SD."""
    out = []
    ref_mean, ref_sd = TABLE2["CCNet"]
    for row, (t_paper, p_paper) in TABLE2_TP.items():
        mean, sd = TABLE2[row]
        for n in sorted({TABLE2_N[row], PAIRS_PER_GROUP}):
            for test, equal_var in (("Student", True), ("Welch", False)):
                for ddof in (1, 0):
                    method = f"{test}, SD as ddof {ddof}, n {n} vs {TABLE2_N['CCNet']}"
                    for k, quantity, paper in ((0, "t", t_paper), (1, "p", p_paper)):
                        def f(m1, s1, m2, s2, k=k, n=n, equal_var=equal_var, ddof=ddof):
                            return _t(m1, s1, n, m2, s2, TABLE2_N["CCNet"], equal_var, ddof)[k]
                        out.append(_record("Table 2", row, quantity, method, paper,
                                           *span(f, mean, sd, ref_mean, ref_sd)))
        for df in sorted({30, TABLE2_N[row] + TABLE2_N["CCNet"] - 2}):
            out.append(_record("Table 2", row, "p", f"two-sided p of the printed t, t distribution with {df} df",
                               p_paper, *span(lambda t, df=df: 2 * stats.t.sf(abs(t), df), t_paper)))
        implied = _implied_df(float(t_paper), float(p_paper))
        out.append(_record("Table 2", row, "df", "degrees of freedom at which the printed t gives the printed p",
                           None, implied))
    return out + _grim_records("Table 2", TABLE2, {r: (TABLE2_N[r], PAIRS_PER_GROUP) for r in TABLE2})


def _implied_df(t: float, p: float) -> float:
    from scipy.optimize import brentq

    return float(brentq(lambda df: math.log(2 * stats.t.sf(abs(t), df)) - math.log(p), 2.0, 1e4))


# ---------------------------------------------------------------- Table 3
def table3_records() -> list[dict]:
    """Table 3: GRIM/GRIMMER of each group (16 participants; 15 too, the DAE-LSTM count of §4.5)."""
    return _grim_records("Table 3", TABLE3, {r: (15, 16) for r in TABLE3})


# ---------------------------------------------------------------- Table 4
def _anova_from_summaries(means, sds, n: int, ddof: int) -> dict:
    """One-way ANOVA of groups of ``n`` from their means and SDs (with ``ddof``)."""
    means, sds = np.asarray(means, dtype=float), np.asarray(sds, dtype=float)
    ss_b = n * ((means - means.mean()) ** 2).sum()
    ss_w = ((n - ddof) * sds ** 2).sum()
    df_b, df_w = len(means) - 1, len(means) * (n - 1)
    f = (ss_b / df_b) / (ss_w / df_w)
    return {"SS between": ss_b, "SS within": ss_w, "SS total": ss_b + ss_w, "MS between": ss_b / df_b,
            "MS within": ss_w / df_w, "F": f, "P-value": stats.f.sf(f, df_b, df_w)}


def table4_records(alpha: float = 0.05) -> list[dict]:
    """Table 4 from Table 2's four groups (16 each, as Table 4's df say), and Table 4's own
    consistency: MS from its SS and df, F from its MS, p and F-critical from its F and df."""
    paper = {"SS between": TABLE4["SS"][0], "SS within": TABLE4["SS"][1], "SS total": TABLE4["SS"][2],
             "MS between": TABLE4["MS"][0], "MS within": TABLE4["MS"][1], "F": TABLE4["F"],
             "P-value": TABLE4["P-value"]}
    printed = [x for row in TABLE2.values() for x in row]  # mean, sd of CCNet, DAE-LSTM, ERD-4LR, PFNN
    out = []
    for ddof in (1, 0):
        for quantity, value in paper.items():
            def f(*v, quantity=quantity, ddof=ddof):
                return _anova_from_summaries(v[0::2], v[1::2], PAIRS_PER_GROUP, ddof)[quantity]
            out.append(_record("Table 4", "ANOVA", quantity, f"from Table 2's means and SDs (ddof {ddof}), 16 per group",
                               value, *span(f, *printed)))
    df_b, df_w, _ = TABLE4["df"]
    ss_b, ss_w, ss_t = TABLE4["SS"]
    checks = [("SS total", "SS between + SS within (printed)", ss_t, span(lambda a, b: a + b, ss_b, ss_w)),
              ("MS between", f"printed SS between / {df_b}", TABLE4["MS"][0], span(lambda a: a / df_b, ss_b)),
              ("MS within", f"printed SS within / {df_w}", TABLE4["MS"][1], span(lambda a: a / df_w, ss_w)),
              ("F", "printed MS between / MS within", TABLE4["F"], span(lambda a, b: a / b, *TABLE4["MS"])),
              ("P-value", f"F distribution ({df_b}, {df_w}) at the printed F", TABLE4["P-value"],
               span(lambda f: stats.f.sf(f, df_b, df_w), TABLE4["F"])),
              ("F-critical", f"F distribution ({df_b}, {df_w}), {1 - alpha:g} quantile", TABLE4["F-critical"],
               span(lambda: stats.f.ppf(1 - alpha, df_b, df_w)))]
    out += [_record("Table 4", "ANOVA", q, m, paper_value, *s) for q, m, paper_value, s in checks]
    return out


def recheck() -> pd.DataFrame:
    """Every recomputation above, one row each: ``table``, ``row``, ``quantity``, ``method``,
    ``paper``, ``value`` (from the printed inputs), ``low`` / ``high`` (over their rounding) and
    ``agrees`` (None where the paper prints nothing to compare)."""
    return pd.DataFrame(table2_records() + table3_records() + table4_records())


# ---------------------------------------------------------------- power
def effect_sizes() -> pd.DataFrame:
    """Standardised effects the paper's tables imply: Table 2's baseline vs CCNet (Cohen's d,
    pooled sample SD, SDs read as ddof 1) and Table 3's CCNet count against chance (8 of 16; d =
    (mean - 8) / std, one-sample)."""
    rows = []
    m0, s0 = map(float, TABLE2["CCNet"])
    for row in TABLE2_TP:
        m, s = map(float, TABLE2[row])
        n, n0 = TABLE2_N[row], TABLE2_N["CCNet"]
        pooled = math.sqrt(((n - 1) * s ** 2 + (n0 - 1) * s0 ** 2) / (n + n0 - 2))
        rows.append(dict(effect=f"Table 2: CCNet vs {row}", design="two-sample", d=(m0 - m) / pooled))
    for row, (m, s) in TABLE3.items():
        rows.append(dict(effect=f"Table 3: {row} against chance", design="one-sample",
                         d=(float(m) - CHANCE) / float(s)))
    return pd.DataFrame(rows)


def power_table(targets=(0.8, 0.95), alpha: float = 0.05, n_paper: int = 16) -> pd.DataFrame:
    """Participants needed (per group for two-sample designs) for each effect of
    :func:`effect_sizes` and for Cohen's small / medium / large effects (0.2, 0.5, 0.8), at
    each power of ``targets``, and the power the paper's ``n_paper`` participants had."""
    fx = effect_sizes()
    for d, name in ((0.2, "small"), (0.5, "medium"), (0.8, "large")):
        for design in pw.DESIGNS:
            fx.loc[len(fx)] = dict(effect=f"Cohen's {name} effect", design=design, d=d)
    for target in targets:
        fx[f"n for power {target:g}"] = [pw.sample_size(abs(r.d), target, r.design, alpha) for r in fx.itertuples()]
    fx[f"power with n = {n_paper}"] = [pw.power(abs(r.d), n_paper, r.design, alpha) for r in fx.itertuples()]
    return fx
