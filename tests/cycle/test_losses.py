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

from .test_closure_run import SCENARIO


ROLLING = "rolling_friction = 0\nfriction = 0.3"


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


def _text(diameter, cycles, extra=""):
    """The CI closure scene with masses of *diameter*; *extra* lines go to [dem]."""
    text = (SCENARIO % (cycles, "no_flow")).replace('diameter = ["1.6 m", "2.0 m"]', f'diameter = "{diameter}"')
    if extra:
        text = text.replace('max_time = "3 s"', 'max_time = "15 s"')
    return text.replace("[dem]", "[dem]\n" + extra)


def _run(path, diameter, cycles=4, extra=""):
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
    text = (SCENARIO % (1, "no_flow")).replace("[closure]", '[closure]\nloss_limit = 0.9\narea = ["-6 m", "6 m", "-8 m", "8 m"]')
    setup = closure_setup(parse_scenario(text))
    assert setup.loss_limit == 0.9 and setup.area == (-6.0, 6.0, -8.0, 8.0)
    from breachflow.errors import BreachflowError

    with pytest.raises(BreachflowError, match="area"):
        closure_setup(parse_scenario((SCENARIO % (1, "no_flow")).replace("[closure]", '[closure]\narea = ["6 m", "-6 m", "0 m", "1 m"]')))
