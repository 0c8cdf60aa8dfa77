"""Seal chains behind rock dams of uniform units: ``seal = [..., "auto"]`` chooses the shortest run of EN 13383
gradings from the last named layer to the dam's rock that passes both filter rules, and a dam for which no
run exists ends with a "no seal designable" verdict. Checked against hand arithmetic of the rules and an
exhaustive search over every ordered subset of the standard gradings."""
import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.leakage import PolderLeakage, undesignable_seal
from breachflow.errors import InputError
from breachflow.materials import get_material
from breachflow.materials.rock import STANDARD_GRADINGS
from breachflow.materials.seal import (DEFAULT_SEAL_GRADINGS, Grading, bridge_filters, check_filter,
                                       standard_filter_gradings)
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with

K = (math.pi / 6.0) ** (1.0 / 3.0)  # nominal diameter of a sphere over its diameter
RHO = 2650.0
NAMED = [DEFAULT_SEAL_GRADINGS[n] for n in ("sand", "gravel", "quarry_run")]


def sphere_rock(d):
    return Grading("rock dam", K * d, K * d, K * d, porosity=0.4)


def passes(chain):
    try:
        check_filter(chain)
        return True
    except InputError:
        return False


@pytest.mark.parametrize("d, last", [(3.0, "LMA_60_300"), (4.0, "HMA_300_1000"), (5.0, "HMA_1000_3000")])
def test_the_layer_on_3_4_5_m_spheres_straddles_a_fifth_of_their_nominal_diameter(d, last):
    """Both rules at the rock: D15_rock / D85_last <= 5 and D15_rock / D15_last >= 5, i.e. the layer's D_n15 <=
    D_n/5 <= D_n85: by hand, M15 <= rho (D_n/5)^3 <= M85 (3 m: 300 kg, 4 m: 711 kg, 5 m: 1,388 kg)."""
    c = PolderLeakage("1 cm/day", area="4900 ha", seal=["sand", "gravel", "quarry_run", "auto"])
    c.bind_rock(sphere_rock(d))
    assert c.undesignable is None
    assert [g.name for g in c.seal_layers] == ["sand", "gravel", "quarry_run", last]
    m_need = RHO * (K * d / 5.0) ** 3
    assert m_need == pytest.approx({3.0: 299.7, 4.0: 710.4, 5.0: 1387.5}[d], rel=1e-3)
    m15, m85 = get_material(last).mass_at_fraction([0.15, 0.85])
    assert m15 <= m_need <= m85
    # the named layers alone end at quarry run (D85 0.2 m): the rock's D_n / 0.2 m is above 5 by hand
    assert K * d / 0.2 > 5 and not passes([*NAMED, sphere_rock(d)])
    # the chain the shipped typical breach uses behind 10-15 t rock fails behind these spheres: LMA_40_200's
    # D_n85 is too small for them (retention above 5)
    lma = Grading.from_rock(get_material("LMA_40_200"))
    assert K * d / lma.d85 > 5


def _exhaustive(base, rock, cands, max_layers=4):
    """Shortest length of any ordered run (by D15) of distinct *cands* from *base* to *rock* passing
    check_filter, by trying every subset; None if none."""
    for n in range(0, max_layers + 1):
        for sub in itertools.combinations(sorted(cands, key=lambda g: g.d15), n):
            if passes([base, *sub, rock]):
                return n
    return None


def test_auto_finds_the_shortest_run_or_says_none_exists_over_a_sweep_of_sizes():
    """From 1 to 8 m spheres in 5 cm steps and after each of the named layers: bridge_filters's run passes
    check_filter and is as short as the exhaustive search's; where it finds none, neither does the search."""
    cands = standard_filter_gradings()
    assert sorted(g.name for g in cands) == sorted(STANDARD_GRADINGS)
    found = refused = 0
    for d in np.arange(1.0, 8.0001, 0.05):
        rock = sphere_rock(float(d))
        for base in NAMED[1:]:
            n = _exhaustive(base, rock, cands)
            try:
                run = bridge_filters(base, rock, cands)
            except InputError as exc:
                assert str(exc).startswith("no seal designable"), exc
                assert n is None, (d, base.name, n)
                refused += 1
                continue
            assert passes([base, *run, rock]), (d, base.name, [g.name for g in run])
            assert len(run) == n, (d, base.name, [g.name for g in run], n)
            found += 1
    assert found > 100 and refused > 10  # both outcomes occur in the sweep


def test_a_size_between_two_gradings_has_no_seal_with_the_ratios_named():
    """3.2 m spheres: D_n = 2.579 m, the layer on the rock needs D_n15 <= 0.516 m <= D_n85. LMA 60-300 ends at
    D_n85 0.509 m (retention 2.579/0.509 = 5.07 > 5) and HMA 300-1000 starts at D_n15 0.521 m (permeability
    2.579/0.521 = 4.95 < 5): no standard grading straddles it."""
    c = PolderLeakage("1 cm/day", area="4900 ha", seal=["sand", "gravel", "quarry_run", "auto"])
    c.bind_rock(sphere_rock(3.2))
    msg = c.undesignable
    assert msg.startswith("[criteria] polder_leakage: no seal designable")
    lma, hma = (Grading.from_rock(get_material(n)) for n in ("LMA_60_300", "HMA_300_1000"))
    assert K * 3.2 / lma.d85 == pytest.approx(5.07, abs=0.01) and K * 3.2 / hma.d15 == pytest.approx(4.95, abs=0.01)
    assert "HMA_300_1000: retention 3.41 <= 5, permeability 4.95 < 5" in msg
    assert "LMA_60_300: retention 5.07 > 5" in msg
    assert "D85 >= 0.516 m" in msg and "D15 <= 0.516 m" in msg
    assert undesignable_seal([c]) == msg


def test_auto_must_end_a_list_of_named_layers():
    for bad in (["auto"], ["sand", "auto", "gravel"], ["sand", "auto", "auto"]):
        with pytest.raises(InputError, match="may only end a list of named layers"):
            PolderLeakage("1 cm/day", area="1 ha", seal=bad)


CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def _porous_scene(seal, diameter):
    return scenario_with(CI_CLOSURE, {"closure.remap": "porous", "placement.diameter": diameter,
                                      "criteria.mode": "all", "criteria.max_speed": None,
                                      "criteria.overflow_discharge": "0.5 m^3/s",
                                      "criteria.polder_leakage": {"threshold": "1 cm/day", "seal": seal},
                                      "polder.area": "100 ha"})


def test_an_explicit_chain_that_breaks_a_rule_is_refused_before_the_run():
    """Today's behaviour for a listed chain: the typical breach's chain behind 4 m spheres is refused when the
    scenario is read, naming the interface and its ratio (D_n 3.224 m / LMA 40-200's D_n85 0.4445 m = 7.25)."""
    text = _porous_scene(["sand", "gravel", "quarry_run", "LMA_40_200"], "4 m")
    with pytest.raises(InputError, match=r"LMA_40_200 would wash out through rock dam: D15_rock dam/D85_LMA_40_200 "
                                         r"= 7.25 > 5"):
        closure_setup(parse_scenario(text))
    s = closure_setup(parse_scenario(_porous_scene(["sand", "gravel", "quarry_run", "auto"], "4 m")))
    crit = next(c for c in s.criteria.items if c.name == "polder_leakage")
    assert [g.name for g in crit.seal_layers][-1] == "HMA_300_1000" and undesignable_seal(s.criteria) is None


def test_a_run_whose_seal_cannot_be_designed_ends_before_its_first_cycle_with_that_verdict(tmp_path):
    """No silent pass and no rock placed in vain: the run ends after the open-breach solve, not closed, its
    verdict the criterion's "no seal designable" statement (sand cannot lie on any EN 13383 grading: the
    finest, LMA 5-40, has D_n15 0.145 m, 242 x sand's D85 of 0.6 mm)."""
    from breachflow.cycle.main import run_closure

    path = tmp_path / "scene.toml"
    path.write_text(_porous_scene(["sand", "auto"], ["1.6 m", "2.0 m"]))
    res = run_closure(path, tmp_path / "run")
    assert not res.closed and res.cycles == 0 and res.tonnage == 0.0
    assert res.verdict.startswith("[criteria] polder_leakage: no seal designable"), res.verdict
    assert "from sand to rock dam" in res.verdict


def test_an_ensemble_says_before_running_which_members_have_no_seal(tmp_path):
    """The typical feasibility ensemble with a 3.2 m mass size added: its members are not refused (the others
    run), but the check before running counts the ones that will end with "no seal designable"."""
    from breachflow.ensemble.execute import check_members, plan

    root = Path(__file__).resolve().parents[2]
    text = (root / "examples" / "ensembles" / "typical_feasibility.toml").read_text()
    text = text.replace('values = ["3 m", "4 m", "5 m"]', 'values = ["3.2 m", "4 m"]')
    text = text.replace('values = ["1900 kg/m^3", "2300 kg/m^3", "2650 kg/m^3"]', 'values = ["2650 kg/m^3"]')
    text = text.replace("values = [10, 20, 30]", "values = [10]")
    spec = tmp_path / "gap.toml"
    spec.write_text(text)
    _, _, _, tasks = plan(spec, out=tmp_path / "out")
    assert len(tasks) == 2
    warnings = check_members(tasks)
    assert any("no seal designable" in w and "(1 of 2 members)" in w for w in warnings), warnings


def test_an_ensemble_member_is_feasible_only_if_its_seal_is_done_inside_the_window():
    """The closure is done when the seal is in (delivered after the rock): a member whose rock is placed at
    14 h but whose seal is finished at 16 h does not fit a 15.1 h window; without a plan (no timeline) the
    last cycle's operation time counts."""
    from types import SimpleNamespace

    from breachflow.ensemble.closure import finish_time

    rock_only = SimpleNamespace(operation_time=14 * 3600.0, plan=None)
    sealed = SimpleNamespace(operation_time=14 * 3600.0, plan={"finish_s": 16 * 3600.0})
    window = 4900e4 * 2.0 / 1800.0  # the typical breach's linear window, 15.1 h
    assert finish_time(rock_only) == 14 * 3600.0 <= window
    assert finish_time(sealed) == 16 * 3600.0 > window


def test_auto_applies_the_criterion_s_own_limits():
    """A stricter retention limit of 4: HMA 300-1000 on 4 m spheres (retention 3.224/0.757 = 4.26) no longer
    passes and no other grading does, while HMA 1000-3000 on 5 m spheres (4.030/1.088 = 3.70) still does."""
    # (sand on gravel, 4.17, breaks a limit of 4 itself: the named layers start at gravel here)
    strict = dict(seal=["gravel", "quarry_run", "auto"], retention_limit=4)
    c4 = PolderLeakage("1 cm/day", area="4900 ha", **strict)
    c4.bind_rock(sphere_rock(4.0))
    assert c4.undesignable and "retention D15_rock/D85 <= 4" in c4.undesignable
    c5 = PolderLeakage("1 cm/day", area="4900 ha", **strict)
    c5.bind_rock(sphere_rock(5.0))
    assert c5.undesignable is None and c5.seal_layers[-1].name == "HMA_1000_3000"
