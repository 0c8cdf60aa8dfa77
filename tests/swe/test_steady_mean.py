"""Steady state of a flow that never settles: the running mean of the breach discharge (issue 16).

``run_to_steady(average=True)`` judges convergence on the batch-means mean of the section discharge and
leaves the time-mean state. Scene: a 4 m gap in a wall between a basin whose level oscillates (±0.15 m,
period 6 s) and a channel held at a fixed level; the discharge through the gap swings between about 9
and 22 m³/s for ever, so the rate test never passes and a plain re-solve stops at ``t_max`` at whatever
phase it reached. Two re-solves started half a period apart must agree on the mean within the error they
report, at several tolerances. (At 5e-4 the mean's slow rise — 0.3 % between the
halves of 120–360 s of a plain run — keeps one of them from converging within the 1500 s given here.)
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.swe.steady_mean import BatchMeans
from breachflow.swe import SWESimulation
from breachflow.swe.domain import BoundaryCondition, uniform_grid

PERIOD = 6.0
SECTION = (-6.0, 6.0, 0.0)


def tidal_gap():
    times = np.arange(0.0, 4000.01, 0.25)
    dom = uniform_grid(-6, 6, -20, 20, 1.0, bed=0.0, manning=0.02,
                       obstacle=lambda X, Y: (np.abs(Y) < 1.0) & (np.abs(X) > 2.0),
                       initial_surface=lambda X, Y: np.where(Y < 0, 2.0, 1.6))
    dom.boundaries = {"south": [BoundaryCondition.water_level(2.0 + 0.15 * np.sin(2 * np.pi * times / PERIOD),
                                                              times=times)],
                      "north": [BoundaryCondition.water_level(1.6)]}
    return dom


def resolve(start, tol, average, t_max=1500.0):
    sim = SWESimulation(tidal_gap())
    sim.advance_to(start)
    hist = sim.run_to_steady(tol, t_max, section=SECTION, average=average)
    return sim, hist


def test_the_scene_never_settles_and_a_plain_resolve_stops_at_a_random_phase():
    a, ha = resolve(150.0, 2e-3, False, t_max=100.0)
    b, hb = resolve(150.0 + 0.5 * PERIOD, 2e-3, False, t_max=100.0)
    assert not ha.converged and not hb.converged
    q = np.array(ha.section_discharge)
    assert q.max() - q.min() > 0.5 * q.mean()  # it oscillates: swings of more than half the mean
    assert abs(a.section_discharge(SECTION) - b.section_discharge(SECTION)) > 2.0  # m³/s, phase-dependent


@pytest.mark.parametrize("tol", [2e-3, 1.4e-3, 1e-3])
def test_resolves_from_different_starts_agree_on_the_mean_within_their_error(tol):
    runs = [resolve(start, tol, True) for start in (150.0, 150.0 + 0.5 * PERIOD)]
    means, errors = [], []
    for sim, hist in runs:
        assert hist.converged and hist.averaged
        mean, err = hist.section_mean[-1], hist.section_se[-1]
        assert err <= tol * (hist.time[1] - hist.time[0]) * abs(mean) * (1 + 1e-12)
        t0, t1 = hist.average_interval
        assert t1 - t0 >= 4 * PERIOD
        # the state left is the time mean: its discharge is the mean of the samples (Q is linear in h v)
        assert sim.section_discharge(SECTION) == pytest.approx(mean, rel=1e-9)
        means.append(mean)
        errors.append(err)
    assert abs(means[0] - means[1]) <= 3.0 * math.hypot(*errors)


def test_average_needs_a_section():
    with pytest.raises(InputError, match="section"):
        SWESimulation(tidal_gap()).run_to_steady(1e-3, 10.0, average=True)


def test_batch_means_of_a_noisy_oscillation_cover_the_true_mean():
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 2000.0, 0.5)
    for phase in np.linspace(0.0, 2 * np.pi, 5, endpoint=False):
        # AR(1) noise (correlation time 10 s) on a sine of period 13 s around a mean of 10
        e = np.zeros(t.size)
        for k in range(1, t.size):
            e[k] = 0.95 * e[k - 1] + 0.3 * rng.standard_normal()
        q = 10.0 + np.sin(2 * np.pi * t / 13.0 + phase) + e
        acc = BatchMeans(8)
        for tk, qk in zip(t, q):
            acc.add(tk, qk)
        mean, err = acc.stats()
        assert 8 <= acc.batches <= 16
        assert abs(mean - 10.0) <= 3.0 * err
        assert err < 0.5  # the standard error of this record is about 0.1 (AR(1) N_eff ~ 100); drift term adds


def test_batch_means_error_includes_a_slow_drift():
    t = np.arange(0.0, 1000.0, 1.0)
    acc = BatchMeans(10)
    for tk in t:
        acc.add(tk, 10.0 + 1e-3 * tk)  # no scatter: all of the error is the drift
    mean, err = acc.stats()
    assert acc.drifting()
    t0, t1 = acc.interval()
    # the halves' means differ by slope × W / 2; half of that is in the error
    assert err >= 0.5 * 1e-3 * 0.5 * (t1 - t0) * (1 - 1e-6)
