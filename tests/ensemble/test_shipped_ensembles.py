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
        assert table["site"]["preset"] == "typical_breach"  # from the screening set-up in the file
        assert table["hydro"]["resolution"] == "4 m"
        # the varied values land in the member's scenario, the rest comes from the file's set-up
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


@pytest.mark.slow
def test_the_small_example_runs_end_to_end_without_warnings(tmp_path):
    """`breachflow ensemble examples/ensembles/small.toml` (the README's first ensemble): 2 rock sizes x 2
    placement seeds, every member computed, P(closure) per rock size from its 2 replicates, and no warning
    printed by the run (a new user's first ensemble must not greet them with warnings)."""
    import os
    import subprocess
    import sys

    import xarray as xr

    small = ROOT / "examples" / "ensembles" / "small.toml"
    out = tmp_path / "small"
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    res = subprocess.run([sys.executable, "-W", "default", "-m", "breachflow", "ensemble", str(small), "--workers", "1",
                          "--out", str(out)], capture_output=True, text=True, timeout=1800, env=env)
    assert res.returncode == 0, res.stderr[-3000:]
    text = res.stdout + res.stderr
    assert "warning" not in text.lower(), text[-3000:]
    with xr.open_dataset(out / "ensemble.nc") as ds:
        assert ds.sizes.get("replicate") == 2 and ds.sizes.get("mass_size") == 2, dict(ds.sizes)
        from breachflow.ensemble.dataset import STATUS_OK

        status = np.asarray(ds["member_status"].values)
        assert (status == STATUS_OK).all(), status
        p = np.asarray(ds["closure_probability"].values, float)
        assert p.shape == (2,) and np.all((p >= 0) & (p <= 1)), p


@pytest.mark.parametrize("path", sorted((ROOT / "examples" / "ensembles").glob("*.toml")), ids=lambda p: p.name)
def test_every_member_of_every_shipped_ensemble_passes_the_check_before_running(path, tmp_path):
    """What `breachflow ensemble FILE` checks first (scenario, runner checks such as the seal's filter rules)
    accepts every member of every shipped ensemble: a user running the README's command gets a run, not a
    refusal."""
    _, _, _, tasks = plan(path, out=tmp_path / "out")
    assert tasks
    check_members(tasks)  # raises InputError naming each refused member
