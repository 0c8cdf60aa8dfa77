"""Masses carried out of the breach area: removal, counts, tonnage, the verdict, Izbash's speed."""
import json
import math

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.cycle.losses import breach_area, izbash_speed
from breachflow.cycle.config import demo_breach
from breachflow.scenario.config import parse_scenario

from .test_closure_run import ci_scene


ROLLING = {"dem.rolling_friction": 0, "dem.friction": 0.3}


def test_izbash_speed_matches_the_published_coefficient():
    # Izbash (1935): u_c / sqrt(Delta g d) = 1.7 for embedded stones, i.e. C sqrt(2) with C = 1.20
    delta = 1.65
    for d in (0.5, 2.0, 4.0):
        u = izbash_speed(d, 2650.0, c=1.20)
        assert u / math.sqrt(delta * 9.80665 * d) == pytest.approx(1.7, rel=2e-3)
    assert izbash_speed(2.0, 2650.0) == pytest.approx(0.86 * math.sqrt(2 * 9.80665 * 1.65 * 2.0), rel=1e-12)


def test_breach_area_is_the_levee_footprint_over_the_breach_plus_one_diameter():
    sc = demo_breach()  # 12 m breach, crown 3 m, 3 m high, slopes 1V:2H both sides
    assert breach_area(sc, 2.0) == pytest.approx((-8.0, 8.0, -(1.5 + 6.0 + 2.0), 1.5 + 6.0 + 2.0))


def _text(diameter, cycles, extra=None):
    """The CI closure scene with masses of *diameter*; *extra*: changes of [dem] (then a 15 s cycle cap)."""
    return ci_scene(cycles, "no_flow", {"placement.diameter": diameter, **({"dem.max_time": "15 s", **extra} if extra else {})})


def _run(path, diameter, cycles=4, extra=None):
    text = _text(diameter, cycles, extra)
    run = ClosureRun(closure_setup(parse_scenario(text)), path, text)
    run.run()
    return run


def test_small_masses_are_carried_away_and_the_run_ends_with_a_verdict(tmp_path):
    # round masses without rolling resistance in the ~4.5 m/s breach flow roll away downstream
    run = _run(tmp_path / "small", "1 m", extra=ROLLING)
    reps = run.reports
    assert len(reps) < 4 and reps[-1].verdict.startswith("not closable with D = 1 m masses")
    assert "Izbash critical speed" in reps[-1].verdict and not reps[-1].closed
    man = json.loads((tmp_path / "small" / "manifest.json").read_text())
    assert man["final"]["verdict"] == reps[-1].verdict
    # the counts are the masses the DEM retired, and each of them lies outside the breach area
    rec = run.rundir.load_restart(len(reps))
    active = rec["dem.state.active"]
    lost = np.flatnonzero(~active)
    assert lost.size == reps[-1].left_domain == man["final"]["lost_masses"] > 0
    assert reps[-1].lost_tonnage == pytest.approx(rec["dem.state.mass"][lost].sum() / 1000.0, rel=1e-12)
    x0, x1, y0, y1 = run.setup.area
    p = rec["dem.state.pos"][lost]
    eps = 1e-9  # the DEM retires a mass where its centre reaches the box face
    assert np.all((p[:, 0] <= x0 + eps) | (p[:, 0] >= x1 - eps) | (p[:, 1] <= y0 + eps) | (p[:, 1] >= y1 - eps))
    assert reps[-1].lost_cycle_tonnage > 0.5 * reps[-1].placed_cycle_tonnage
    # a finished run with a verdict is not continued by a resume
    text = _text("1 m", 4, ROLLING)
    again = ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "small", text, resume=True)
    assert again.run() == [] and again.rundir.last_cycle() == len(reps)


def test_large_masses_stay_and_no_verdict(tmp_path):
    run = _run(tmp_path / "large", "2.0 m", cycles=2)
    assert all(r.verdict == "" for r in run.reports) and run.reports[-1].left_domain == 0


def test_loss_limit_and_area_come_from_the_scenario(tmp_path):
    text = ci_scene(1, "no_flow", {"closure.loss_limit": 0.9, "closure.area": ["-6 m", "6 m", "-8 m", "8 m"]})
    setup = closure_setup(parse_scenario(text))
    assert setup.loss_limit == 0.9 and setup.area == (-6.0, 6.0, -8.0, 8.0)
    from breachflow.errors import BreachflowError

    with pytest.raises(BreachflowError, match="area"):
        closure_setup(parse_scenario(ci_scene(1, "no_flow", {"closure.area": ["6 m", "-6 m", "0 m", "1 m"]})))


def test_rolling_speed_balances_drag_and_rolling_resistance():
    """``rolling_speed``: the drag 1/2 rho C_D A u^2 equals mu_r times the submerged weight. For D = 4 m the
    Reynolds number (~3e7) is past the report law's cap C_D = 0.40 (docs/theory.md, *Fluid forces on a mass*), so u^2 = mu_r Delta g (2 D / 3) / 0.20
    by hand; for smaller masses the balance is checked with the law's own C_D(Re)."""
    from breachflow.cycle.losses import rolling_speed
    from breachflow.fluid.drag import DRAG_LAWS

    g, delta = 9.80665, 1.65
    assert rolling_speed(4.0, 2650.0, 0.3) == pytest.approx(math.sqrt(0.3 * delta * g * (2 * 4.0 / 3) / 0.20), rel=1e-9)
    assert rolling_speed(4.0, 2650.0, 0.3) == pytest.approx(8.045, abs=1e-3)
    law = DRAG_LAWS.create("report")
    for d in (0.05, 0.5, 2.0):
        u = rolling_speed(d, 2650.0, 0.3)
        drag = 0.5 * 1000.0 * float(law.cd(u * d / 1e-6)) * math.pi * d * d / 4 * u * u
        assert drag == pytest.approx(0.3 * 1650.0 * g * math.pi * d ** 3 / 6, rel=1e-8)
    assert rolling_speed(2.0, 2650.0, 0.0) == 0.0


@pytest.mark.parametrize("ratio,rolls", [(0.9, False), (1.1, True)])
def test_a_lone_sphere_on_a_flat_bed_rolls_above_the_rolling_speed(ratio, rolls):
    """The DEM (rolling resistance of dem/contact_law.py, the closure's default rock) and the fluid forces
    (uniform profile) agree with the verdict's ``rolling_speed``: a 2 m sphere resting on a flat bed under
    a current of 0.9 u_roll stays, under 1.1 u_roll it rolls away."""
    from breachflow.cycle.losses import rolling_speed
    from breachflow.dem import DemSimulation, HeightField, Material
    from breachflow.fluid.field import UniformWater
    from breachflow.fluid.forces import FluidForces

    D = 2.0
    u_roll = rolling_speed(D, 2650.0, 0.3)
    mat = Material(density=2650.0, kn=2.0e7, friction=0.6, rolling_friction=0.3).with_restitution(
        0.3, 2650.0 * math.pi / 6 * D ** 3)
    x = np.linspace(-50.0, 50.0, 11)
    bed = HeightField(x, x, np.zeros((11, 11)), mat)
    water = UniformWater(surface=3.0 * D, u=ratio * u_roll, v=0.0, bed=0.0)
    sim = DemSimulation(boundaries=[bed], models=[FluidForces(water, air=None, velocity_profile="uniform")], sleeping=False, static_models=True)
    sim.add_particles(np.array([[0.0, 0.0, 0.5 * D - 2e-3]]), 0.5 * D, mat)
    sim.step(int(math.ceil(4.0 / sim.dt)))
    moved = float(np.hypot(*sim.state.pos[0, :2]))
    assert (moved > 0.5 * D) is rolls, moved


def test_the_verdict_says_which_speed_governs_and_counts_older_masses():
    """Below Izbash's speed but above the lone-mass rolling speed: the verdict says the rolling governs; lost
    masses placed in earlier cycles are counted as such (not "6 of 5 masses")."""
    from breachflow.cycle.losses import not_closable_verdict

    v = not_closable_verdict(2, 14, 20, 1243.2, 1776.0, np.full(20, 4.0), np.full(20, 2650.0), 8.46,
                             lost_placed=0, roll_speed=8.05, bed_factor=1.05)
    assert "14 masses (1243.2 t), 0 of them placed in this cycle," in v and "(20 masses, 1776.0 t placed in it)" in v
    assert "8.46 m/s (depth-averaged; 8.88 m/s at the centre of a mass on the bed) is below the Izbash" in v
    assert "above the 8.05 m/s at which a lone mass rolls on the bare bed" in v and v.endswith("which governs here")
    fast = not_closable_verdict(1, 14, 20, 155.4, 222.0, np.full(20, 2.0), np.full(20, 2650.0), 7.93,
                                lost_placed=14, roll_speed=5.7)
    assert "14 masses (155.4 t) were carried" in fast and "exceeds the Izbash" in fast and "governs" not in fast
