"""Issue 27: impossible or absurd inputs are refused before anything runs, naming the file, line, key and
value (breachflow.scenario.plausibility); the batch de-stacking is no longer quadratic."""
import re
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.cycle.placement import destack
from breachflow.errors import InputError, ParseError
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.plausibility import MAX_CELLS, RANGES
from breachflow.scenario.toml import scenario_with

CI = (Path(__file__).parents[1] / "data" / "ci_closure.toml").read_text()
CALC = """[flood]
surge_height = "2.8 m"
fall_rate = "40 cm/hr"

[polder]
area = "800 ha"
inundation_depth = "90 cm"

[breach]
length = "100 m"
"""
runner = CliRunner()


def _line(text, key):
    return next(i for i, line in enumerate(text.splitlines(), 1) if re.match(rf"\s*{key}\s*=", line))


def test_five_parsecs_is_no_breach_length(tmp_path):
    text = CALC.replace('length = "100 m"', 'length = "5 parsecs"')
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(ParseError) as info:
        parse_scenario(text, path=path)
    e = info.value
    assert e.line == _line(text, "length") and e.path == str(path)
    assert "[breach] length = '5 parsecs' (1.54284e+17 m) is outside the plausible range 0.5 m to 10000 m" in str(e)
    # the calculator and the window command refuse it too (was: t_B = 1.54e-15 h, exit 0)
    res = runner.invoke(app, ["run", str(path)])
    assert res.exit_code != 0 and "plausible range" in str(res.exception)
    res = runner.invoke(app, ["window", "--surge-height", "2.8 m", "--fall-rate", "40 cm/hr", "--polder-area", "800 ha",
                              "--inundation-depth", "90 cm", "--breach-length", "5 parsecs"])
    assert res.exit_code != 0
    assert "--breach-length = '5 parsecs' (1.54284e+17 m) is outside the plausible range" in str(res.exception)


def test_a_parsec_is_1_54e17_m_by_independent_arithmetic():
    # 1 pc = 648000/pi au, 1 au = 149 597 870 700 m (IAU 2012): the value the message shows for 5 pc
    assert 5 * 648000 / np.pi * 149_597_870_700 == pytest.approx(1.54284e17, rel=1e-5)


@pytest.mark.parametrize("batch", [10_000_000, 2_001])
def test_an_absurd_batch_is_refused_at_its_line(batch):
    text = scenario_with(CI, {"placement.batch": batch})
    t0 = time.process_time()
    with pytest.raises(ParseError) as info:
        parse_scenario(text)
    assert time.process_time() - t0 < 5  # refused, not computed: the old code hung in the overlap loop
    assert info.value.line == _line(text, "batch")
    assert f"[placement] batch = {batch} is outside the plausible range 1 to 2000" in str(info.value)


def test_batch_times_cycles_is_bounded():
    text = scenario_with(CI, {"placement.batch": 2000, "criteria.max_cycles": 1000})
    with pytest.raises(ParseError, match=r"batch = 2000 with \[criteria\] max_cycles = 1000 makes up to 2,000,000 masses"):
        parse_scenario(text)


def test_two_millimetre_masses_are_refused():
    """2 mm masses 'rested' 1 m above the water for 24 cycles in a 5 m/s flow (exit 0, nothing lost)."""
    text = scenario_with(CI, {"placement.diameter": ["2 mm", "2 mm"]})
    with pytest.raises(ParseError) as info:
        parse_scenario(text)
    assert info.value.line == _line(text, "diameter")
    assert "[placement] diameter = ['2 mm', '2 mm'] (0.002 m) is outside the plausible range 0.05 m to 25 m" in str(info.value)


def test_a_misspelt_key_is_reported_at_its_own_line():
    text = CI.replace("batch = 3", "bacth = 3")
    with pytest.raises(ParseError) as info:
        parse_scenario(text)
    assert info.value.line == _line(text, "bacth")  # was the line of 'diameter'
    assert "[placement] bacth: unknown key; did you mean 'batch'?" in str(info.value)


@pytest.mark.parametrize("section, key", [(s, k) for (s, k), b in RANGES.items() if b.kind != "count"])
def test_every_bound_refuses_just_outside_and_accepts_just_inside(section, key):
    """For each ranged key: a value 1 % above the upper bound is refused naming the key, 1 % below accepted
    (the check alone: violation() on the raw value, independent of the rest of a scenario)."""
    from breachflow.scenario.plausibility import violation

    b = RANGES[(section, key)]
    unit = {"length": "m", "area": "m^2", "discharge": "m^3/s", "speed": "m/s", "time": "s", "density": "kg/m^3",
            "rate": "m/s", "dimensionless": "", "manning": "s/m^(1/3)"}[b.kind]
    above, inside = f"{b.hi * 1.01!r} {unit}".strip(), f"{b.hi * 0.99!r} {unit}".strip()
    if b.kind in ("dimensionless", "manning"):
        above, inside = b.hi * 1.01, b.hi * 0.99
    why = violation(section, key, above)
    assert why is not None and why.startswith(f"[{section}] {key} = ") and "plausible range" in why
    assert violation(section, key, inside) is None


def test_a_grid_too_large_is_refused_before_it_is_allocated():
    from breachflow.cycle.config import closure_setup

    text = scenario_with(CI, {"site.levee_length_each_side": "15000 m", "site.flood_side_extent": "15000 m",
                              "hydro.resolution": "0.5 m"})
    with pytest.raises(InputError, match="the hydrodynamic grid would have .* cells .*at most " + re.escape(f"{MAX_CELLS:.3g}")):
        closure_setup(parse_scenario(text))


def _naive(pos, r):
    """The original quadratic de-stacking, as the reference."""
    pos = pos.copy()
    for i in range(1, len(pos)):
        for j in range(i):
            if np.linalg.norm(pos[i] - pos[j]) < r[i] + r[j]:
                pos[i, 2] = pos[j, 2] + r[i] + r[j] + 1e-3
    return pos


@pytest.mark.parametrize("seed", range(12))
def test_destack_gives_the_quadratic_result(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 80))
    spread = float(rng.choice([0.0, 0.5, 3.0, 40.0]))
    pos = np.column_stack([rng.uniform(-spread, spread, (n, 2)), rng.uniform(0, 0.5, n)])
    r = rng.uniform(0.1, 1.0, n)
    np.testing.assert_array_equal(destack(pos.copy(), r), _naive(pos, r))


def test_destack_of_a_large_spread_batch_compares_neighbours_only():
    """2000 masses along a 2 km line: each meets only its neighbours' cells (the quadratic loop made
    2,000,000 comparisons). No mass overlaps another afterwards."""
    n = 2000
    pos = np.column_stack([np.linspace(0, 2000, n), np.zeros(n), np.zeros(n)])
    r = np.full(n, 0.6)
    out = destack(pos.copy(), r)
    from scipy.spatial import cKDTree

    pairs = cKDTree(out).query_pairs(1.2 - 1e-9)
    assert not pairs
