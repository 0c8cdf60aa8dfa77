"""The cycle files carry each mass's material and the coefficients it moved with, so that a notebook can tell
the bags from the rock: checked against the materials' own values (breachflow.materials), per mass."""
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.io import RunDirectory
from breachflow.materials import get_material
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with

CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def _flags(da):
    return dict(zip(np.asarray(da.attrs["flag_values"]).tolist(), da.attrs["flag_meanings"].split()))


def test_mix_cycle_files_name_each_mass_material_and_its_coefficients(tmp_path):
    names = ["HMA_6000_10000", "big_bag"]
    text = scenario_with(CI_CLOSURE, {"placement.diameter": None, "placement.material": names,
                                      "placement.fractions": [0.5, 0.5], "criteria.max_cycles": 2})
    ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "run", text).run()
    run = RunDirectory(tmp_path / "run")
    mats = [get_material(n) for n in names]
    for g in run.completed_cycles():
        with xr.open_dataset(run.cycle_path(g)) as ds:
            ds = ds.squeeze(drop=True) if "cycle" in ds.dims else ds
            flags = _flags(ds["particle_material"])
            assert flags == {-1: "not_placed", 0: "HMA_6000_10000", 1: "big_bag"}
            idx = np.asarray(ds["particle_material"].values).astype(int).ravel()
            placed = np.asarray(ds["particle_placed_cycle"].values).ravel() > 0
            assert placed.sum() == 3 * g and np.all(idx[placed] >= 0) and np.all(idx[~placed] == -1)
            rho = np.asarray(ds["particle_density"].values, float).ravel()
            # the density written tells rock (2650) from bags (1990) independently of the index
            for k, m in enumerate(mats):
                sel = placed & (idx == k)
                assert np.all(rho[sel] == m.density)
                for var, want in (("particle_drag_coefficient", m.drag_coefficient),
                                  ("particle_friction", m.friction),
                                  ("particle_rolling_friction", m.rolling_friction)):
                    np.testing.assert_array_equal(np.asarray(ds[var].values).ravel()[sel], want, err_msg=var)
                lift = np.asarray(ds["particle_lift_coefficient"].values).ravel()[sel]
                assert (np.all(np.isnan(lift)) if m.lift_coefficient is None else np.all(lift == m.lift_coefficient))
            assert ds["particle_drag_coefficient"].attrs["units"] == "1"
            assert set(np.unique(idx[placed])) <= {0, 1}
    # over both cycles both materials were placed (6 masses, half the tonnage each)
    with xr.open_dataset(run.cycle_path(2)) as ds:
        idx = np.asarray(ds["particle_material"].values).astype(int).ravel()
        assert {0, 1} <= set(idx.tolist())
        rho = np.asarray(ds["particle_density"].values, float).ravel()
        mass = np.asarray(ds["particle_mass"].values, float).ravel()
    # the closure plan's tonnage per material reads the names: the masses of each material's density
    from breachflow.cycle.plan import _materials

    rows = {r["material"]: r for r in _materials(run, 2)}
    assert set(rows) == set(names)
    for m in mats:
        assert rows[m.name]["placed_t"] == pytest.approx(mass[rho == m.density].sum() / 1000.0, rel=1e-12)


def _run(tmp_path, name, material: str, fractions=None):
    """A two-cycle run of *material* (TOML text of the value: a name, a table, a list)."""
    ch = {"placement.diameter": None, "criteria.max_cycles": 2}
    if fractions is not None:
        ch["placement.fractions"] = fractions
    text = scenario_with(CI_CLOSURE, ch).replace("[placement]\n", f"[placement]\nmaterial = {material}\n", 1)
    setup = closure_setup(parse_scenario(text))
    ClosureRun(setup, tmp_path / name, text).run()
    return RunDirectory(tmp_path / name), setup


def test_a_material_stating_the_run_xi_is_bit_identical_and_a_mix_writes_each_mass_xi(tmp_path):
    plain, setup = _run(tmp_path, "plain", '"HMA_6000_10000"')
    xi = setup.dem.xi  # the run's [fluid] xi
    same, _ = _run(tmp_path, "same", f'{{ name = "HMA_6000_10000", added_mass_coefficient = {xi!r} }}')
    for g in (1, 2):
        with xr.open_dataset(plain.cycle_path(g)) as a, xr.open_dataset(same.cycle_path(g)) as b:
            assert set(a.variables) == set(b.variables)
            for v in a.variables:
                np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)
            placed = np.asarray(a["particle_placed_cycle"].values).ravel() > 0
            np.testing.assert_array_equal(np.asarray(a["particle_added_mass_coefficient"].values).ravel()[placed], xi)
    mix, _ = _run(tmp_path, "mix", '["HMA_6000_10000", { name = "big_bag", added_mass_coefficient = 1.0 }]', [0.5, 0.5])
    with xr.open_dataset(mix.cycle_path(2)) as ds:
        idx = np.asarray(ds["particle_material"].values).astype(int).ravel()
        xis = np.asarray(ds["particle_added_mass_coefficient"].values).ravel()
        assert {0, 1} <= set(idx.tolist())
        np.testing.assert_array_equal(xis[idx == 0], xi)
        np.testing.assert_array_equal(xis[idx == 1], 1.0)
