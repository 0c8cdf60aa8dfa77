"""The example site's control section on its own terrain and on the verdict check's finer grid (slow: about
60 CPU s, the 0.5 m solve most of it).

On the example site's terrain the cell beside the breach's west head on the levee line holds a film of water in
the open-breach solve at 1 m and 0.5 m cells (a few 1e-5 m, above the solver's dry threshold): the breach
channel's wall is there all the same (:data:`breachflow.swe.section.CHANNEL_DEPTH_FRACTION`). The control
section's mean speed must be the critical speed of the 12 m opening, ``(g Q / T)^{1/3}`` with the breach
discharge ``Q`` and ``T`` the opening's width from the scenario (independent arithmetic: Chow 1959,
*Open-channel hydraulics*, ch. 3), and agree between the two grids within the check's 2 % tolerance.
"""
import re
from pathlib import Path

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import control_speed, section_discharge
from breachflow.scenario import parse_scenario

SITE = Path(__file__).resolve().parents[2] / "examples" / "site" / "site.toml"
G = 9.81
WIDTH = 12.0  # breach_length of examples/site/site.toml


def _open_breach(cell: float):
    text = SITE.read_text()
    assert 'breach_length = "12 m"' in text and 'breach_wall_slope = 0' in text
    text = re.sub(r'(?m)^resolution = "[^"]*"', f'resolution = "{cell:g} m"', text)
    s = closure_setup(parse_scenario(text, path=SITE))
    snap = s.solver.solve(s.domain)
    return (section_discharge(snap, s.breach_x, s.levee_y, s.flow_sign),
            control_speed(snap, s.breach_x, s.levee_y)[1])


@pytest.mark.slow
def test_the_example_sites_control_speed_is_critical_and_grid_converged():
    runs = {cell: _open_breach(cell) for cell in (1.0, 0.5)}
    for cell, (q, vc) in runs.items():
        assert np.isfinite(vc), f"{cell} m: no control section found"
        assert vc == pytest.approx((G * abs(q) / WIDTH) ** (1 / 3), rel=0.01), cell
    (q1, v1), (q2, v2) = runs[1.0], runs[0.5]
    assert abs(q2 - q1) / abs(q1) < 0.02
    assert abs(v2 - v1) / v1 < 0.02
