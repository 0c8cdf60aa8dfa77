"""A nested fine grid around the breach in a coarse domain (issue 16; ``[hydro] refine``) against the
uniformly fine solution.

The default scene's breach (12 m in a 3 m levee) in a larger domain (60 m of levee each side, 60 m flood
side, 48 m polder): the coarse domain at 2 m cells, the nested grid at 1 m around the breach (the default
box, breach ± (B/2 + 3 B) along the levee, ± 3 B across: 84 x 72 m, 47 % of the domain), against
the whole domain at 1 m. Stated differences of the open breach's steady state within 2 B of the breach
centre (cells wet in both): breach discharge within 0.5 % (the coarse 2 m field alone is 1.2 % off),
mean |Δ speed| below 0.05 m/s and mean |Δ depth| below 0.01 m, largest speed within 1 %; measured
+0.12 %, 0.007 m/s, 0.001 m and 0.03 % (the figures are printed with ``pytest -s``).
"""
import numpy as np

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import section_discharge
from breachflow.hydro.nested import consistency
from breachflow.scenario.config import parse_scenario

from .._scenes import LARGE_DEMO_SITE

SCENE = """
[scenario]
name = "refine"
""" + LARGE_DEMO_SITE + """[hydro]
resolution = "%s"
tolerance = "1e-4 1/s"
%s
"""


def test_nested_refinement_matches_the_uniformly_fine_solution_near_the_breach():
    nested = closure_setup(parse_scenario(SCENE % ("2 m", 'refine = "1 m"')))
    fine = closure_setup(parse_scenario(SCENE % ("1 m", "")))
    assert nested.solver.mode == "nested" and nested.domain.dx == fine.domain.dx == 1.0
    assert nested.domain.shape[0] * nested.domain.shape[1] < 0.5 * fine.domain.shape[0] * fine.domain.shape[1]
    ds_n = nested.solver.solve(nested.domain)
    ds_f = fine.solver.solve(fine.domain)
    assert nested.solver.last.history.converged and fine.solver.cold.last.history.converged
    q_n = section_discharge(ds_n, nested.breach_x, nested.levee_y)
    q_f = section_discharge(ds_f, fine.breach_x, fine.levee_y)
    B = fine.breach_x[1] - fine.breach_x[0]
    c = consistency(ds_n, ds_f, (0.0, fine.levee_y), 2.0 * B)
    print(f"\nnested 2 m + 1 m vs uniform 1 m within 2 B = {2 * B:g} m ({c['cells']} cells): Q {q_n:.2f} vs {q_f:.2f} m3/s "
          f"({100 * (q_n / q_f - 1):+.2f} %), speed max/mean |diff| {c['max_speed_diff']:.3f}/{c['mean_speed_diff']:.4f} m/s, "
          f"depth max/mean |diff| {c['max_depth_diff']:.3f}/{c['mean_depth_diff']:.4f} m, peak speed "
          f"{c['local_peak_speed']:.3f} vs {c['regional_peak_speed']:.3f} m/s")
    assert abs(q_n / q_f - 1.0) < 0.005
    assert c["mean_speed_diff"] < 0.05 and c["mean_depth_diff"] < 0.01
    assert abs(c["local_peak_speed"] / c["regional_peak_speed"] - 1.0) < 0.01
    # the coarse field alone is further from the fine one than the nested grid (the refinement matters)
    coarse = nested.solver.regional
    q_c = section_discharge(coarse, nested.breach_x, nested.levee_y)
    print(f"coarse 2 m alone: Q {q_c:.2f} m3/s ({100 * (q_c / q_f - 1):+.2f} %)")
    assert abs(q_c / q_f - 1.0) > abs(q_n / q_f - 1.0)
