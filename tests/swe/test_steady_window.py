"""The steady window of ``run_to_steady``: a warm start from a nearby steady state is not steady until the
flow has had one long-wave crossing of the domain to respond, and the breach discharge has stopped
moving over it (docs/verdict-check.md, *Re-solves that settle*)."""
import math
from pathlib import Path

import numpy as np
import pytest

from breachflow.errors import BreachflowError, InputError
from breachflow.swe import SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid
from breachflow.swe.solver import WINDOW_CHANGE, window_change_estimate

G = 9.81


def _channel(q_in: float, length: float = 200.0):
    # 10 m wide channel along y fed with q_in m²/s at the south end: 10 q_in m³/s through every row at steady state
    return uniform_grid(0, 10, 0, length, 2.0, bed=lambda X, Y: 5.0 - 1e-3 * Y, manning=0.03, initial_surface=6.0,
                        boundaries={"south": [BC.inflow(q_in)], "north": [BC.outflow()]})


SECTION = (-1.0, 11.0, 180.0)


@pytest.fixture(scope="module")
def steady_20():
    sim = SWESimulation(_channel(2.0))
    hist = sim.run_to_steady(1e-6, 5000.0, section=SECTION)
    assert hist.converged and sim.section_discharge(SECTION) == pytest.approx(20.0, rel=1e-3)
    return sim.snapshot(derived=False)


def _near_section(dom):
    X, Y = np.meshgrid(dom.x, dom.y)
    return np.abs(Y - SECTION[2]) <= 10.0


@pytest.mark.parametrize("check", [2.0, 5.0])
def test_a_warm_start_waits_for_the_wave_from_the_boundary(steady_20, check):
    """The inflow raised from 20 to 24 m³/s (continuity: 24 m³/s through every row once steady). Judged near the
    section only (as a closure judges the breach vicinity), the rate test finds nothing changing there before the
    bore from the inflow arrives and calls the old state steady; with the window the solve marches at least one
    crossing and reads the new discharge."""
    reads = {}
    for window in (None, "auto"):
        dom = _channel(2.4)
        sim = SWESimulation(dom, initial=steady_20)
        hist = sim.run_to_steady(2e-3, 3000.0, check_interval=check, region=_near_section(dom), section=SECTION,
                                 window=window)
        assert hist.converged
        reads[window] = (sim.t, sim.section_discharge(SECTION), hist)
    t_off, q_off, _ = reads[None]
    t_on, q_on, hist = reads["auto"]
    # the window is one long-wave crossing of the channel's 200 m at its largest depth
    depth = float(steady_20.depth.max())
    assert hist.window == pytest.approx(200.0 / math.sqrt(G * depth), rel=1e-2)
    assert t_off == pytest.approx(check)  # one check: the failure the window is for
    assert q_off == pytest.approx(20.0, rel=1e-3)
    assert t_on >= hist.window
    # the bore has passed and the discharge is the new one within 3 % (the rest: the channel's slow storage
    # relaxation, which a tighter tolerance settles, test_a_tight_tolerance_settles_the_storage below)
    assert abs(q_on / 24.0 - 1.0) < 0.03


def test_a_tight_tolerance_settles_the_storage(steady_20):
    dom = _channel(2.4)
    sim = SWESimulation(dom, initial=steady_20)
    hist = sim.run_to_steady(1e-6, 5000.0, section=SECTION, window="auto")
    assert hist.converged
    assert sim.section_discharge(SECTION) == pytest.approx(24.0, rel=1e-3)


def test_a_settled_state_passes_after_one_window(steady_20):
    """Nothing to change: the solve stops at the first check after one window, and reads the same flow."""
    sim = SWESimulation(_channel(2.0), initial=steady_20)
    hist = sim.run_to_steady(2e-3, 3000.0, check_interval=5.0, section=SECTION, window=30.0)
    assert hist.converged
    assert sim.t == pytest.approx(30.0)
    assert sim.section_discharge(SECTION) == pytest.approx(20.0, rel=1e-3)
    assert hist.window_range[-1] < 1e-3 * 20.0


def test_the_window_caps_at_t_max(steady_20):
    sim = SWESimulation(_channel(2.4), initial=steady_20)
    hist = sim.run_to_steady(2e-3, 20.0, check_interval=5.0, section=SECTION, window=60.0)
    assert not hist.converged and sim.t == pytest.approx(20.0)


# ---------------------------------------------------------------- the estimate of the change still to come
def _sampled(f, t_end, dt=1.0):
    t = np.arange(dt, t_end + 1e-9, dt)
    return t, f(t), float(f(np.array([0.0]))[0])


def test_a_geometric_approach_is_extrapolated_exactly():
    """Q = Q_inf - A exp(-t / tau) sampled at the window's ends and middle: Aitken's Δ² gives Q_inf exactly."""
    q_inf, a, tau, window = 1700.0, 200.0, 40.0, 60.0
    t, q, q0 = _sampled(lambda t: q_inf - a * np.exp(-t / tau), 150.0)
    rng, remaining = window_change_estimate(t, q, 0.0, q0, window)
    assert remaining == pytest.approx(q_inf - q[-1], rel=1e-9)
    assert rng == pytest.approx(q[-1] - (q_inf - a * math.exp(-(150.0 - window) / tau)), rel=1e-9)


def test_a_flow_that_only_begins_to_move_is_not_settled():
    """A slow start (the change speeding up over the window, a logistic's first half): the estimate is one more
    window at the pace of its second half, and it keeps the solve going where the range alone would not."""
    f = lambda t: 1500.0 + 250.0 / (1.0 + np.exp(-(t - 150.0) / 20.0))
    t, q, q0 = _sampled(f, 90.0)
    rng, remaining = window_change_estimate(t, q, 0.0, q0, 60.0)
    d2 = f(np.array([90.0]))[0] - f(np.array([60.0]))[0]
    assert remaining == pytest.approx(2.0 * d2, rel=1e-9)
    assert rng < WINDOW_CHANGE * 1500.0 < remaining  # the range alone would have let it pass


def test_a_creep_is_judged_by_its_pace():
    """A linear creep (r = 1): the change of one more window; tiny, it passes."""
    t, q, q0 = _sampled(lambda t: 73.0 + 1e-4 * t, 100.0)
    rng, remaining = window_change_estimate(t, q, 0.0, q0, 10.0)
    assert rng == pytest.approx(1e-3, rel=1e-6) and remaining == pytest.approx(1e-3, rel=1e-6)


def test_an_oscillation_counts_half_its_range():
    t, q, q0 = _sampled(lambda t: 100.0 + 0.4 * np.sin(2 * np.pi * t / 20.0), 200.0, dt=0.5)
    rng, remaining = window_change_estimate(t, q, 0.0, q0, 60.0)
    assert rng == pytest.approx(0.8, rel=1e-3)
    assert remaining == pytest.approx(0.5 * rng)


def test_younger_than_the_window_is_not_settled():
    t, q, q0 = _sampled(lambda t: 0.0 * t + 5.0, 30.0)
    assert window_change_estimate(t, q, 0.0, q0, 60.0) == (math.inf, math.inf)


# ---------------------------------------------------------------- errors and scenario keys
def test_a_window_needs_the_section():
    with pytest.raises(InputError, match="section"):
        SWESimulation(_channel(2.0)).run_to_steady(1e-3, 10.0, window=30.0)


@pytest.mark.parametrize("window, change", [(-1.0, 0.01), (math.inf, 0.01), (10.0, 0.0), (10.0, 1.5)])
def test_bad_window_values_are_clear_errors(window, change):
    with pytest.raises(InputError, match="window"):
        SWESimulation(_channel(2.0)).run_to_steady(1e-3, 10.0, section=SECTION, window=window, window_change=change)


def _hydro(extra: str):
    from breachflow.scenario import parse_scenario

    return parse_scenario(f'[hydro]\nsolver = "swe"\n{extra}\n', path=Path("closure.toml"))["hydro"]


def test_the_scenario_keys():
    assert _hydro("").steady_window == "auto" and _hydro("").steady_window_change == WINDOW_CHANGE
    h = _hydro('steady_window = "2 min"\nsteady_window_change = 0.005')
    assert h.steady_window == pytest.approx(120.0) and h.steady_window_change == pytest.approx(0.005)
    assert _hydro('steady_window = "0 s"').steady_window == 0.0


@pytest.mark.parametrize("line, key", [('steady_window = "-5 s"', "steady_window"),
                                       ('steady_window = "5 m"', "steady_window"),
                                       ("steady_window_change = 1.5", "steady_window_change"),
                                       ("steady_window_change = 0", "steady_window_change")])
def test_bad_scenario_keys_name_file_and_key(line, key):
    with pytest.raises(BreachflowError, match=rf"closure\.toml:3: \[hydro\] {key}"):
        _hydro(line)
