"""Analysis of a two-alternative forced-choice study, as in the CCNet paper (§4.5, Tables 2-4).

Input: the kit's ``key.json`` and the participants' downloaded JSON files (:mod:`.kit`).

1. :func:`answers_table`: one row per participant and question, with the model chosen.
2. :func:`validity`: the paper's three rules: a questionnaire is discarded if it took less
   than ``min_seconds`` (the paper: 10 min, the shortest time needed to judge every pair), if
   it has a blank answer, or if its choices contain an intransitive triad (A over B, B over C,
   C over A).
3. :func:`group_counts`: per valid participant and group, how many times the group's counted
   clip was chosen (the paper's "number of generated sequences selected").
4. :func:`t_tests` (Table 2), :func:`group_means` (Table 3), :func:`anova_table` (Table 4),
   every statistic from :mod:`scipy.stats`.

Which t-test: every participant judges every group, so two groups' counts are paired by
participant and the paired test (``ttest_rel``) is the right one; it uses the participants
valid in both groups. Student's (``equal_var=True``) and Welch's (``equal_var=False``)
independent-samples tests are reported beside it because the paper's p-values follow from its
t-values with 30 degrees of freedom, i.e. an independent-samples test on 16 + 16 participants
(:mod:`.paper`). Welch's needs no equal-variance assumption and is the one to prefer when the
groups are different people.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

PAPER_MIN_SECONDS = 600.0  # the paper's 10 minutes
TESTS = ("paired", "student", "welch")


def read_key(path: str | Path) -> dict:
    return json.loads(Path(path).read_text())


def read_responses(paths) -> list[dict]:
    """The downloaded JSON files: a folder (every ``*.json`` in it, sorted) or a list of files."""
    if isinstance(paths, (str, Path)) and Path(paths).is_dir():
        paths = sorted(Path(paths).glob("*.json"))
    return [json.loads(Path(p).read_text()) for p in paths]


def answers_table(responses: list[dict], key: dict) -> pd.DataFrame:
    """One row per (participant, question): ``group``, ``choice`` (left / right / None),
    ``chosen_item``, ``chosen_model``, ``winner`` / ``loser`` items (None if blank),
    ``counted`` (the group's counted clip was chosen) and ``seconds`` on the question.

    Raises ValueError for a response of another kit, a duplicate participant code, or a
    question missing from a response.
    """
    questions = {q["id"]: q for q in key["questions"]}
    seen, rows = set(), []
    for r in responses:
        who = r["participant"]
        if r.get("kit") != key["kit"]:
            raise ValueError(f"response of {who!r} is for kit {r.get('kit')!r}, the key is {key['kit']!r}")
        if who in seen:
            raise ValueError(f"two responses from participant {who!r}")
        seen.add(who)
        answered = {a["question"]: a for a in r["answers"]}
        if set(answered) != set(questions):
            raise ValueError(f"response of {who!r} does not answer exactly the kit's {len(questions)} questions")
        for qid, q in questions.items():
            choice = answered[qid]["choice"]
            other = {"left": "right", "right": "left"}.get(choice)
            rows.append(dict(participant=who, question=qid, group=q["group"], choice=choice,
                             chosen_item=q[choice]["item"] if choice else None,
                             chosen_model=q[choice]["model"] if choice else None,
                             winner=q[choice]["item"] if choice else None,
                             loser=q[other]["item"] if choice else None,
                             counted=choice == q["counted"], seconds=float(answered[qid]["seconds"])))
    return pd.DataFrame(rows)


def intransitive_triads(winners, losers) -> int:
    """Number of intransitive triads (A over B, B over C, C over A) among these choices.

    With ``W[i, j] = 1`` when item i was chosen over item j, the closed walks of length 3 are
    exactly the directed triangles (no item is compared with itself), each counted three
    times: trace(W^3) / 3.
    """
    items = sorted(set(winners) | set(losers))
    index = {it: k for k, it in enumerate(items)}
    w = np.zeros((len(items), len(items)), dtype=np.int64)
    w[[index[a] for a in winners], [index[b] for b in losers]] = 1
    return int(np.trace(w @ w @ w)) // 3


def validity(responses: list[dict], key: dict, min_seconds: float = PAPER_MIN_SECONDS) -> pd.DataFrame:
    """Per participant: ``minutes`` taken, ``blank`` answers, intransitive ``triads`` and
    ``valid`` (none of the paper's three reasons to discard), with the ``reasons`` spelt out."""
    answers = answers_table(responses, key)
    rows = []
    for r in responses:
        mine = answers[answers.participant == r["participant"]]
        chosen = mine.dropna(subset=["winner"])
        seconds = (r["finished"] - r["started"]) / 1000.0
        row = dict(participant=r["participant"], minutes=seconds / 60.0, blank=int(mine.choice.isna().sum()),
                   triads=intransitive_triads(chosen.winner, chosen.loser))
        reasons = [why for why, bad in ((f"under {min_seconds / 60:g} min", seconds < min_seconds),
                                        ("blank answers", row["blank"] > 0),
                                        ("intransitive triads", row["triads"] > 0)) if bad]
        rows.append(dict(row, valid=not reasons, reasons="; ".join(reasons)))
    return pd.DataFrame(rows).set_index("participant")


def group_counts(answers: pd.DataFrame, participants=None) -> pd.DataFrame:
    """(participant x group) number of questions of the group in which its counted clip was
    chosen, for ``participants`` (default: everyone in ``answers``)."""
    if participants is not None:
        answers = answers[answers.participant.isin(list(participants))]
    counts = answers.groupby(["participant", "group"], sort=False)["counted"].sum().unstack("group")
    return counts.astype(float)


def _ttest(x: np.ndarray, y: np.ndarray, test: str):
    if test == "paired":
        return stats.ttest_rel(x, y)
    if test in ("student", "welch"):
        return stats.ttest_ind(x, y, equal_var=test == "student")
    raise ValueError(f"test must be one of {TESTS}, got {test!r}")


def t_tests(counts: pd.DataFrame, reference: str, others, tests=TESTS) -> pd.DataFrame:
    """Table 2: each group of ``others`` against ``reference`` under each test.

    t is computed as (other - reference), the paper's sign. Columns: ``group``, ``test``,
    ``n_other``, ``n_reference``, means and sample standard deviations (ddof 1), ``t``, ``df``, ``p``
    (two-sided). The paired test uses the participants with a count in both groups.
    """
    rows = []
    for other in others:
        for test in tests:
            pair = counts[[other, reference]].dropna() if test == "paired" else counts[[other, reference]]
            x, y = pair[other].dropna().to_numpy(), pair[reference].dropna().to_numpy()
            res = _ttest(x, y, test)
            rows.append(dict(group=other, test=test, n_other=len(x), n_reference=len(y),
                             mean_other=x.mean(), std_other=x.std(ddof=1), mean_reference=y.mean(),
                             std_reference=y.std(ddof=1), t=float(res.statistic), df=float(res.df),
                             p=float(res.pvalue)))
    return pd.DataFrame(rows)


def group_means(counts: pd.DataFrame, groups=None) -> pd.DataFrame:
    """Table 3: per group, participants ``n``, ``mean`` and sample ``std`` (ddof 1) of the counts."""
    groups = list(counts.columns if groups is None else groups)
    return pd.DataFrame({g: dict(n=int(counts[g].notna().sum()), mean=counts[g].mean(), std=counts[g].std(ddof=1))
                         for g in groups}).T


def anova_table(counts: pd.DataFrame, groups, alpha: float = 0.05) -> pd.DataFrame:
    """Table 4: one-way ANOVA of the counts of ``groups``, laid out as the paper's table.

    Rows SS, df, MS, F, P-value, F-critical; columns Between Groups, Within Groups, Total.
    F and p come from ``scipy.stats.f_oneway``, F-critical from ``scipy.stats.f.ppf(1 - alpha)``;
    the sums of squares, which scipy does not return, are the usual sums over the data.
    """
    samples = [counts[g].dropna().to_numpy() for g in groups]
    res = stats.f_oneway(*samples)
    everything = np.concatenate(samples)
    ss_within = sum(((s - s.mean()) ** 2).sum() for s in samples)
    ss_total = ((everything - everything.mean()) ** 2).sum()
    df_between, df_within = len(samples) - 1, len(everything) - len(samples)
    ss_between = ss_total - ss_within
    table = {"Between Groups": {"SS": ss_between, "df": df_between, "MS": ss_between / df_between,
                                "F": float(res.statistic), "P-value": float(res.pvalue),
                                "F-critical": float(stats.f.ppf(1 - alpha, df_between, df_within))},
             "Within Groups": {"SS": ss_within, "df": df_within, "MS": ss_within / df_within},
             "Total": {"SS": ss_total, "df": len(everything) - 1}}
    return pd.DataFrame(table).reindex(["SS", "df", "MS", "F", "P-value", "F-critical"])
