"""Running mean of an unsteady "steady state" with its standard error (issue 16; docs/theory.md, *Shallow-water equations* steady state).

A flow that sheds eddies (a jet through a breach, the wakes of the levee heads) never stops changing:
its rates of change stay above any tight tolerance and a re-solve stopped at the tolerance or at
``t_max`` lands at a random phase of the oscillation. Its steady-state answer is the time mean.
:class:`BatchMeans` accumulates a sampled signal (the breach discharge) and optional fields (depth, unit
discharges) in batches and gives the mean with its standard error by the method of batch means
(Law & Kelton, *Simulation Modeling and Analysis*, §9.5.3; Fishman's doubling batch sizes): the record
since the start of the averaging is cut into K consecutive batches of equal length, the batch means
``m_k`` are taken as independent, and

    mean = Σ q / n,     SE = sd(m_k) / √K,

and the error reported is ``sqrt(SE² + (Δ/2)²)`` with Δ the difference between the means of the first
and the second half of the batches (a slow drift of the mean that the batch scatter does not show).

Batches double in length whenever ``slots`` of them are full (pairs are merged), so K stays between
``slots / 2`` and ``slots`` and each batch grows past the signal's correlation time (the shedding
period) as the record grows; the memory is ``slots`` copies of the fields. Drift (the end of a
transient, a slowly filling pool) is tested by comparing the means of the first and the second half of
the batches against the pooled within-half scatter (a two-sample t statistic above ``drift_t``); on
drift the first half is dropped and the averaging goes on from the second half. The caller may also drop
the batches before a given time (``run_to_steady`` keeps only the second half of the record: the rule
of discarding the first half as the warm-up, Law & Kelton §9.5.1).
"""
from __future__ import annotations

import math

import numpy as np


class BatchMeans:
    """Batch-means accumulator of a scalar signal and of optional fields (module docstring).

    *batch_samples*: samples per batch at the start; *slots*: the number of batches (even, >= 4) at which
    pairs are merged; *drift_t*: the t statistic above which the first half counts as a transient.
    """

    def __init__(self, batch_samples: int, slots: int = 16, drift_t: float = 3.0):
        if batch_samples < 1 or slots < 4 or slots % 2:
            raise ValueError("BatchMeans: batch_samples >= 1 and an even slots >= 4 are needed")
        self.batch_samples, self.slots, self.drift_t = int(batch_samples), int(slots), float(drift_t)
        self.closed: list[dict] = []
        self.open: dict | None = None

    def add(self, t: float, q: float, fields=()) -> None:
        """One sample at time *t* (s): the signal *q* and the fields (arrays, summed in place)."""
        if self.open is None:
            self.open = {"n": 0, "q": 0.0, "t0": t, "t1": t, "f": [np.zeros_like(np.asarray(f, float)) for f in fields]}
        b = self.open
        b["n"] += 1
        b["q"] += float(q)
        b["t1"] = t
        for acc, f in zip(b["f"], fields):
            acc += f
        if b["n"] >= self.batch_samples:
            self.closed.append(b)
            self.open = None
            if len(self.closed) >= self.slots:
                self.closed = [_merge(self.closed[k], self.closed[k + 1]) for k in range(0, len(self.closed), 2)]
                self.batch_samples *= 2

    @property
    def batches(self) -> int:
        return len(self.closed)

    def batch_means(self) -> np.ndarray:
        return np.array([b["q"] / b["n"] for b in self.closed])

    def stats(self) -> tuple[float, float]:
        """Mean of the signal over the closed batches and its error: the batch-means standard error and,
        from 4 batches on, half the difference between the means of the first and second half of the
        batches (a slow drift the batch scatter does not show), added in quadrature
        ``sqrt(SE² + (Δ/2)²)``. NaN below 2 batches."""
        if not self.closed:
            return math.nan, math.nan
        n = sum(b["n"] for b in self.closed)
        mean = sum(b["q"] for b in self.closed) / n
        return mean, batch_error(self.batch_means())

    def drifting(self) -> bool:
        """Do the first and the second half of the batches differ (t statistic above ``drift_t``)? Needs
        at least 2 batches in each half; False otherwise."""
        m = self.batch_means()
        k = m.size // 2
        if k < 2:
            return False
        a, b = m[:k], m[-k:]
        pooled = math.sqrt(0.5 * (np.var(a, ddof=1) + np.var(b, ddof=1)) * 2.0 / k)
        d = abs(a.mean() - b.mean())
        return d > self.drift_t * pooled if pooled > 0 else d > 0

    def drop_first_half(self) -> None:
        self.closed = self.closed[len(self.closed) // 2:]

    def drop_before(self, t: float) -> None:
        """Drop the closed batches that start before time *t* (s): the start-up transient."""
        self.closed = [b for b in self.closed if b["t0"] >= t]

    def interval(self) -> tuple[float, float]:
        """Simulated time (s) of the first and the last sample of the closed batches."""
        if not self.closed:
            return math.nan, math.nan
        return self.closed[0]["t0"], self.closed[-1]["t1"]

    def mean_fields(self) -> list[np.ndarray]:
        """The fields' means over the closed batches."""
        n = sum(b["n"] for b in self.closed)
        return [sum(b["f"][i] for b in self.closed) / n for i in range(len(self.closed[0]["f"]))]


def batch_error(batch_means) -> float:
    """Error of the mean of consecutive batch means *m* (``BatchMeans.stats``): the standard error
    ``sd(m) / sqrt(K)`` and, from 4 batches on, half the difference between the means of the first and the
    second half of the batches, added in quadrature. NaN below 2 batches."""
    m = np.asarray(batch_means, float)
    if m.size < 2:
        return math.nan
    se = float(np.std(m, ddof=1) / math.sqrt(m.size))
    k = m.size // 2
    drift = 0.5 * abs(m[:k].mean() - m[-k:].mean()) if k >= 2 else 0.0
    return math.hypot(se, drift)


def series_mean(values, batches: int = 8) -> tuple[float, float]:
    """Mean of an equally spaced record *values* and its error: the record cut into *batches* consecutive
    batches of (nearly) equal length (fewer when it is shorter), the error that of :func:`batch_error` on
    their means (Law & Kelton, *Simulation Modeling and Analysis*, §9.5.3). ``(nan, nan)`` for an empty
    record; the error is NaN below 2 samples."""
    v = np.asarray(values, float)
    if v.size == 0:
        return math.nan, math.nan
    parts = np.array_split(v, min(int(batches), v.size))
    return float(v.mean()), batch_error([p.mean() for p in parts])


def _merge(a: dict, b: dict) -> dict:
    for acc, f in zip(a["f"], b["f"]):
        acc += f
    return {"n": a["n"] + b["n"], "q": a["q"] + b["q"], "t0": a["t0"], "t1": b["t1"], "f": a["f"]}
