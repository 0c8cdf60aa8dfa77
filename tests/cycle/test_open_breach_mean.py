"""The verdict check's open breach as a time mean (``[check] flow_mean_windows``,
:func:`breachflow.ensemble.check.open_breach_mean`).

A steady test accepts one state of a flow that keeps moving; the check marches each grid's open breach on and
compares the time means of the march's second half with their errors. Checked here on a flow whose mean is
known independently: the tidal gap of ``tests/swe/test_steady_mean.py`` (a basin level oscillating ±0.15 m
with a 6 s period behind a 4 m gap; the discharge swings between about 9 and 22 m³/s for ever). Marches
started half a period apart, at opposite phases, must agree with each other and with a plain average of the
discharge over 100 periods within the errors they report; the error of
:func:`~breachflow.swe.steady_mean.series_mean` is checked on records with a known mean and a known drift.
"""
from __future__ import annotations

import math
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from breachflow.ensemble.check import CheckRun, judge, open_breach_mean
from breachflow.swe import SWESimulation
from breachflow.swe.steady_mean import series_mean

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "swe"))
from test_steady_mean import PERIOD, SECTION, tidal_gap  # noqa: E402

GAP = types.SimpleNamespace(breach_x=(SECTION[0], SECTION[1]), levee_y=SECTION[2], flow_sign=1.0)


def test_series_mean_covers_the_true_mean_of_correlated_noise():
    rng = np.random.default_rng(11)
    hits = 0
    for k in range(200):
        e = np.zeros(400)
        for i in range(1, e.size):  # AR(1), correlation time about 10 samples
            e[i] = 0.9 * e[i - 1] + rng.standard_normal()
        mean, err = series_mean(5.0 + e, 8)
        hits += abs(mean - 5.0) <= 2.0 * err
    assert hits >= 0.85 * 200  # a 2-sigma interval; batch means of 50 samples hold about 5 correlation times


def test_series_mean_error_holds_half_the_drift_between_the_halves():
    v = np.linspace(0.0, 1.0, 800)  # no scatter about the ramp: the batch means' scatter and the drift
    mean, err = series_mean(v, 8)
    m = np.array([p.mean() for p in np.array_split(v, 8)])
    se = np.std(m, ddof=1) / math.sqrt(8)
    assert mean == pytest.approx(0.5)
    assert err == pytest.approx(math.hypot(se, 0.5 * (m[4:].mean() - m[:4].mean())), rel=1e-12)
    assert err >= 0.25 * 0.5  # the halves' means differ by half the ramp
    assert series_mean([], 8)[0] != series_mean([], 8)[0]  # NaN
    assert math.isnan(series_mean([1.0], 8)[1])


def accepted_gap(start):
    sim = SWESimulation(tidal_gap())
    sim.advance_to(start)
    sim.run_to_steady(2e-3, 20.0, section=SECTION)  # stops after 20 s, at the phase it reached
    return sim


def test_marches_from_opposite_phases_agree_with_a_long_plain_average():
    # the independent figure: the discharge averaged over 100 periods, sampled every 0.25 s
    ref = SWESimulation(tidal_gap())
    ref.advance_to(150.0)
    q = []
    while ref.t < 150.0 + 100 * PERIOD - 1e-9:
        ref.advance_to(ref.t + 0.25)
        q.append(ref.section_discharge(SECTION))
    q_ref = float(np.mean(q))
    means = []
    for start in (150.0, 150.0 + 0.5 * PERIOD):
        sim = accepted_gap(start)
        first = sim.section_discharge(SECTION)
        t0, march = sim.t, 20 * sim.crossing_time()  # no steady window: one crossing per window
        figures, interval = open_breach_mean(sim, GAP, 20)
        assert sim.t == pytest.approx(t0 + march)
        assert interval == pytest.approx(0.5 * march)  # the second half is averaged
        assert interval >= 10 * PERIOD
        mean, err = figures["discharge"]
        assert 0 < err < 0.05 * mean
        assert abs(mean - q_ref) <= 2.0 * err + 0.005 * q_ref
        means.append((mean, err, first))
    (m1, e1, f1), (m2, e2, f2) = means
    assert abs(f1 - f2) > 5.0  # the accepted states lie far apart (m³/s) ...
    assert abs(m1 - m2) <= 2.0 * math.hypot(e1, e2)  # ... their time means agree within their errors


def marched(label, size, q, qe, v, ve, interval=200.0):
    return CheckRun(label=label, cell_size=size, seed=-1, closed=None, discharge=q, discharge_error=qe,
                    control_speed=v, control_speed_error=ve, gap_mean_speed=v, gap_max_speed=v + 1,
                    mean_interval=interval)


def closure(label, size, seed, q, v, own=False):
    return CheckRun(label=label, cell_size=size, seed=seed, closed=True, tonnage=1000.0, cycles=4, discharge=q,
                    control_speed=v, gap_mean_speed=v, gap_max_speed=v + 1, own=own)


def test_the_check_judges_time_means_with_their_errors():
    # single states 0.1 % apart; time means +1.5 % (discharge) and +1.0 % (control speed) apart
    own, fine = closure("4 m", 4, 1, 1722.0, 6.13, own=True), closure("2 m", 2, 1, 1723.7, 6.14)
    tight = [own, fine, marched("4 m", 4, 1725.0, 2.0, 6.20, 0.005), marched("2 m", 2, 1750.9, 2.0, 6.262, 0.005)]
    r = judge(tight, 0.02)
    assert r.flow_difference["breach discharge"] == pytest.approx(25.9 / 1725.0)  # the means, not the states
    assert r.flow_difference_error["breach discharge"] == pytest.approx(
        math.hypot(2.0 / 1725.0, 1750.9 * 2.0 / 1725.0 ** 2))
    assert r.flow_mean_intervals == (200.0, 200.0)
    assert r.robust and r.statement.startswith("closed in all 2 runs")
    # the same means with errors whose double takes the discharge's difference past 2 %
    loose = [own, fine, marched("4 m", 4, 1725.0, 6.0, 6.20, 0.005), marched("2 m", 2, 1750.9, 6.0, 6.262, 0.005)]
    r = judge(loose, 0.02)
    assert not r.robust
    assert "open-breach flow not grid-converged (breach discharge +1.5 ± 0.5 % on the finer grid as time means" \
        in r.statement
    assert "control speed" not in r.statement
    rows = dict(r.rows())
    assert rows["  grid difference of the open breach's breach discharge"].startswith("+1.50 ± 0.50 % (time means")  # hypot(6/1725, 1750.9·6/1725²)
    # without a march of the run's grid the closures' single states are compared, as before
    r = judge([own, fine, marched("2 m", 2, 1750.9, 2.0, 6.262, 0.005)], 0.02)
    assert r.flow_difference["breach discharge"] == pytest.approx(1.7 / 1722.0)
    assert r.flow_difference_error["breach discharge"] != r.flow_difference_error["breach discharge"]  # NaN
