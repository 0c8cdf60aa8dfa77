"""The steady-state monitor's section discharge (issue 12, part 3)."""
import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.swe import SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid


def _channel():
    # 10 m wide channel along y, 2 m²/s fed at the south end: 20 m³/s through every row at steady state
    return uniform_grid(0, 10, 0, 200, 2.0, bed=lambda X, Y: 5.0 - 1e-3 * Y, manning=0.03, initial_surface=6.0,
                        boundaries={"south": [BC.inflow(2.0)], "north": [BC.outflow()]})


def test_section_discharge_is_the_row_sum_and_reaches_the_inflow():
    sim = SWESimulation(_channel())
    hist = sim.run_to_steady(1e-5, 3000.0, section=(-1.0, 11.0, 100.0))
    assert hist.converged
    j = int(np.argmin(np.abs(sim.domain.y - 100.0)))
    assert sim.section_discharge((-1.0, 11.0, 100.0)) == pytest.approx(sim.discharge[1][j].sum() * sim.dx, rel=1e-12)
    assert hist.section_discharge[-1] == pytest.approx(20.0, rel=1e-3)
    assert len(hist.section_rate) == len(hist.time) and hist.section_rate[-1] < 1e-5
    assert "convergence_section_discharge" in sim.snapshot(derived=False)


def test_the_section_discharge_keeps_the_run_going_until_it_settles():
    """Depth and discharge rates averaged over the whole channel fall below the tolerance before the
    discharge through one row does: with the section, the monitor waits for it."""
    runs = {}
    for section in (None, (-1.0, 11.0, 180.0)):
        sim = SWESimulation(_channel())
        hist = sim.run_to_steady(2e-3, 3000.0, check_interval=5.0, section=section)
        assert hist.converged
        runs[section is not None] = sim
    probe = (-1.0, 11.0, 180.0)
    err = {k: abs(s.section_discharge(probe) / 20.0 - 1.0) for k, s in runs.items()}
    assert runs[True].t > runs[False].t
    assert err[True] < err[False]


@pytest.mark.parametrize("section", [(0.0, 1.0), "x", (20.0, 30.0, 5.0)])
def test_a_bad_section_is_a_clear_error(section):
    with pytest.raises(InputError, match="section"):
        SWESimulation(_channel()).run_to_steady(1e-3, 10.0, section=section)


def test_the_monitor_judges_the_reported_breach_discharge_not_the_levee_row():
    """A 6 m gap in a levee (walls for |y - 100| < 10 m) with a raised bed (+0.7 m, 3 cells) on the levee
    row: at steady state every row of the gap carries the 20 m³/s fed in (continuity), but the cell-centre
    momentum on and beside the step is not the face flux (the levee row read 20.22, its neighbours 21.06 and
    21.42 m³/s). The monitor reads the closure's breach discharge
    (:func:`breachflow.cycle.criteria.section_discharge`, the median over the gap's rows): the same number,
    and the inflow; before, it read the levee row alone."""
    from breachflow.cycle.criteria import row_discharge, section_discharge

    def bed(X, Y):
        b = 5.0 - 1e-3 * Y
        return np.where((np.abs(Y - 100.5) < 0.5) & (np.abs(X - 5.0) < 1.5), b + 0.7, b)

    dom = uniform_grid(0, 10, 0, 200, 1.0, bed=bed, manning=0.03, initial_surface=6.0,
                       obstacle=lambda X, Y: (np.abs(Y - 100) < 10) & (np.abs(X - 5) > 3),
                       boundaries={"south": [BC.inflow(2.0)], "north": [BC.outflow()]})
    sim = SWESimulation(dom)
    section = (2.0, 8.0, 100.5)
    hist = sim.run_to_steady(1e-5, 3000.0, section=section)
    assert hist.converged
    snap = sim.snapshot(derived=False)
    reported = section_discharge(snap, (2.0, 8.0), 100.5)
    assert sim.section_discharge(section) == pytest.approx(reported, rel=1e-12)
    assert hist.section_discharge[-1] == pytest.approx(reported, rel=1e-12)
    assert reported == pytest.approx(20.0, rel=1e-3)
    # the case discriminates: the levee row's cell-centre sum is not the flux
    assert abs(row_discharge(snap, (2.0, 8.0), 100.5) / 20.0 - 1.0) > 5e-3
