"""Success rates over seeds, with the uncertainty a reader needs to believe them (scipy.stats).

A rate over 20 seeds is a binomial proportion: it is quoted with its 95 % Wilson interval, which stays
inside [0, 1] and is honest at 0/20 and 20/20, where the normal approximation claims certainty. Two
sweeps are compared per cell with an exact test: McNemar's (a binomial test on the seeds whose outcome
changed) when both ran the same seeds, which is the paired question "did my change flip seeds?", and
Fisher's exact test otherwise.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

CONFIDENCE = 0.95
SIGNIFICANT_P = 0.05


@dataclass(frozen=True)
class Rate:
    """k successes of n runs, with its Wilson interval (None for no runs)."""

    k: int
    n: int

    @property
    def value(self) -> float | None:
        return self.k / self.n if self.n else None

    @property
    def interval(self) -> tuple[float, float] | None:
        return wilson(self.k, self.n)

    def text(self) -> str:
        """``18/20 = 90 % [70–97 %]``."""
        if not self.n:
            return "no runs"
        lo, hi = self.interval or (0.0, 0.0)
        return f"{self.k}/{self.n} = {100 * self.k / self.n:.0f} % [{100 * lo:.0f}–{100 * hi:.0f} %]"


def wilson(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float] | None:
    """The Wilson score interval of k/n."""
    if n <= 0:
        return None
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


@dataclass(frozen=True)
class Comparison:
    """Two rates of one cell and what a test says about the difference."""

    a: Rate
    b: Rate
    test: str  # "McNemar (paired on N seeds)" | "Fisher's exact" | "none"
    p: float | None

    @property
    def significant(self) -> bool:
        return self.p is not None and self.p < SIGNIFICANT_P

    def note(self) -> str:
        """The sentence beside the rates: which is better and whether the data say so."""
        if self.p is None:
            return "not comparable (no runs on one side)"
        da, db = self.a.value or 0.0, self.b.value or 0.0
        diff = 100 * (db - da)
        if self.significant:
            word = "better" if db > da else "worse"
            return f"B {word} by {abs(diff):.0f} points, significant (p = {self.p:.3g}, {self.test})"
        if da == db:
            return f"no difference (p = {self.p:.3g}, {self.test})"
        return f"B {diff:+.0f} points, not significant (p = {self.p:.3g}, {self.test}); more seeds may tell"


def compare(a: Mapping[int, bool], b: Mapping[int, bool]) -> Comparison:
    """Outcomes by seed of one cell in sweep A and sweep B: paired when both ran the same seeds."""
    ra, rb = _rate(a.values()), _rate(b.values())
    if not ra.n or not rb.n:
        return Comparison(ra, rb, "none", None)
    if set(a) == set(b):
        flipped_up = sum(1 for s in a if not a[s] and b[s])
        flipped_down = sum(1 for s in a if a[s] and not b[s])
        return Comparison(ra, rb, f"McNemar, paired on {len(a)} seeds", mcnemar_p(flipped_up, flipped_down))
    return Comparison(ra, rb, "Fisher's exact", fisher_p(ra, rb))


def _rate(outcomes: Iterable[bool]) -> Rate:
    values = list(outcomes)
    return Rate(sum(1 for v in values if v), len(values))


def mcnemar_p(up: int, down: int) -> float:
    """Exact McNemar: the seeds that changed are a coin toss under "no effect"."""
    if up + down == 0:
        return 1.0
    from scipy.stats import binomtest

    return float(binomtest(min(up, down), up + down, 0.5).pvalue)


def fisher_p(a: Rate, b: Rate) -> float:
    from scipy.stats import fisher_exact

    table = [[a.k, a.n - a.k], [b.k, b.n - b.k]]
    return float(fisher_exact(table).pvalue)
