"""Power of t-tests and the number of participants they need, from scipy's noncentral t.

Under the alternative, the t statistic of an effect of standardised size d (Cohen's d) follows
a noncentral t distribution: for two independent groups of n each, df = 2n - 2 and noncentrality
d sqrt(n / 2); for one sample or paired differences of n participants (d = mean difference /
SD of the differences), df = n - 1 and noncentrality d sqrt(n). The two-sided power is the
probability that |t| exceeds the critical value ``t.ppf(1 - alpha / 2, df)``.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize, stats

DESIGNS = ("two-sample", "one-sample")  # "one-sample" also covers paired differences


def _df_nc(d: float, n: int, design: str) -> tuple[int, float]:
    if design == "two-sample":
        return 2 * n - 2, d * np.sqrt(n / 2)
    if design == "one-sample":
        return n - 1, d * np.sqrt(n)
    raise ValueError(f"design must be one of {DESIGNS}, got {design!r}")


def power(d: float, n: int, design: str = "two-sample", alpha: float = 0.05) -> float:
    """Two-sided power of the t-test for effect size ``d`` with ``n`` participants (per group
    for ``two-sample``)."""
    df, nc = _df_nc(d, n, design)
    crit = stats.t.ppf(1 - alpha / 2, df)
    # lower tail P(T < -crit) written as P(T' > crit) for T' of noncentrality -nc: scipy's
    # nct.cdf returns nan far in the tail for large effects, its sf does not
    return float(stats.nct.sf(crit, df, nc) + stats.nct.sf(crit, df, -nc))


def sample_size(d: float, target: float = 0.8, design: str = "two-sample", alpha: float = 0.05,
                n_max: int = 100_000) -> int:
    """Smallest n (per group for ``two-sample``; at least 2) whose power reaches ``target``."""
    for n in range(2, n_max + 1):
        if power(d, n, design, alpha) >= target:
            return n
    raise ValueError(f"d = {d} needs more than {n_max} participants")


def detectable_effect(n: int, target: float = 0.8, design: str = "two-sample", alpha: float = 0.05) -> float:
    """The smallest effect size d that ``n`` participants detect with power ``target``."""
    return float(optimize.brentq(lambda d: power(d, n, design, alpha) - target, 1e-6, 50.0, xtol=1e-12))
