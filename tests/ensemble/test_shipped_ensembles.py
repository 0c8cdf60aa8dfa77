"""The ensemble specs shipped in examples/ensembles/ load and give the members their README promises."""
from pathlib import Path

import numpy as np
import pytest

from breachflow.ensemble.execute import check_members, plan
from breachflow.ensemble.spec import load_spec
from breachflow.scenario import closure_window

ROOT = Path(__file__).resolve().parents[2]
TYPICAL = ROOT / "examples" / "ensembles" / "typical_feasibility.toml"


def test_typical_feasibility_is_27_closure_members_on_the_typical_breach():
    spec = load_spec(TYPICAL)
    assert spec.runner == "closure"
    assert spec.dims == ("density", "mass_size", "batch") and spec.shape == (3, 3, 3)
    members = spec.members()
    assert len(members) == 27 and len({m.key for m in members}) == 27
    seen = set()
    for m in members:
        table = spec.member_table(m)
        assert table["site"]["preset"] == "typical_breach"  # from the base scenario file
        assert table["hydro"]["resolution"] == "4 m"
        # the varied values land in the member's scenario, the rest comes from the base file
        assert table["placement"]["density"] == m.values["density"]
        assert table["placement"]["diameter"] == m.values["mass_size"]
        assert table["placement"]["batch"] == m.values["batch"]
        assert table["placement"]["release_height"] == "1 m"
        seen.add((m.values_si["density"], m.values_si["mass_size"], m.values_si["batch"]))
    assert len(seen) == 27
    assert sorted({s[0] for s in seen}) == pytest.approx([1900.0, 2300.0, 2650.0])


def test_typical_feasibility_members_have_a_closure_window(tmp_path):
    """Every member can be judged feasible or not: its scenario gives a finite closure window (a
    member without one would report ``feasible = false`` whatever its closure did)."""
    _, _, _, tasks = plan(TYPICAL, out=tmp_path)
    # the window is the same for every member (nothing varied enters it): 4900 ha x 2 m filled at
    # 1800 m3/s is 9.8e7 m3 / 1800 m3/s = 15.1 h unless the flood falls first
    ds = closure_window(**tasks[0].scenario.scenario().window_kwargs())
    window = float(ds["closure_window"])
    assert np.isfinite(window) and window == pytest.approx(4900e4 * 2.0 / 1800.0, rel=1e-3)
    assert not any("no closure window" in w for w in check_members(tasks[:2]))


def test_a_closure_ensemble_without_a_window_is_told_feasibility_cannot_be_judged(tmp_path):
    text = TYPICAL.read_text(encoding="utf-8").split("# the closure window")[0]
    text = text.replace('base = "../typical_breach.toml"', f'base = "{(ROOT / "examples" / "typical_breach.toml").as_posix()}"')
    spec = tmp_path / "no_window.toml"
    spec.write_text(text, encoding="utf-8")
    _, _, _, tasks = plan(spec, out=tmp_path / "out")
    warnings = check_members(tasks[:2])
    assert any("no closure window" in w and "[flood], [polder], [breach]" in w and "2 of 2" in w for w in warnings)


def test_typical_replicates_are_4_seeds_of_two_cells_with_a_window(tmp_path):
    """The odd cell's spread (README): 2 sizes x 1 batch x 4 placement seeds, every member with the
    typical breach's closure window, seeds differing between replicates and shared across the sizes."""
    path = ROOT / "examples" / "ensembles" / "typical_replicates.toml"
    spec = load_spec(path)
    assert spec.runner == "closure" and spec.replicates == 4
    members = spec.members()
    assert len(members) == 8 and len({m.key for m in members}) == 8
    seeds = {}
    for m in members:
        table = spec.member_table(m)
        assert table["site"]["preset"] == "typical_breach" and table["placement"]["batch"] == 10
        seeds.setdefault(m.values["mass_size"], []).append(m.seed)
    assert sorted(seeds) == ["4 m", "5 m"] and all(len(set(v)) == 4 for v in seeds.values())
    assert sorted(seeds["4 m"]) == sorted(seeds["5 m"])  # common random numbers across the cells
    _, _, _, tasks = plan(path, out=tmp_path)
    ds = closure_window(**tasks[0].scenario.scenario().window_kwargs())
    assert float(ds["closure_window"]) == pytest.approx(4900e4 * 2.0 / 1800.0, rel=1e-3)
    assert not any("no closure window" in w for w in check_members(tasks[:2]))
