"""Options, boundary specifications, warm start, obstacles and raised-bed edits, the solver registry,
the snapshot output with derived fields, and the typical-breach terrain."""
import math

import numpy as np
import pytest
import xarray as xr

from breachflow.errors import InputError, PhysicsError
from breachflow.field import derived
from breachflow.hydro.solvers import HydroSolver, SnapshotSolver, solvers
from breachflow.swe import SWEOptions, SWESimulation, SWESolver
from breachflow.swe.domain import BoundaryCondition as BC, breach_domain, levee_bed, uniform_grid
from breachflow.schemas import validate
from breachflow.scenario import typical_breach

from ._util import channel


def test_courant_above_one_and_bad_options_are_refused():
    with pytest.raises(InputError, match="courant"):
        SWEOptions(courant=1.2)
    with pytest.raises(InputError, match="order"):
        SWEOptions(order=3)
    with pytest.raises(InputError, match="limiter"):
        SWEOptions(limiter="superbee!")
    SWEOptions(courant=1.0)  # 1 itself is allowed


def test_bad_domains_and_boundaries_are_refused():
    with pytest.raises(InputError, match="kind"):
        BC("weir")
    with pytest.raises(InputError, match="needs level"):
        BC("level")
    with pytest.raises(InputError, match="side"):
        uniform_grid(0, 1, 0, 1, 0.1, boundaries={"up": [BC.wall()]})
    with pytest.raises(InputError, match="non-finite"):
        uniform_grid(0, 1, 0, 1, 0.5, bed=np.array([[0, np.nan], [0, 0]]))
    dom = uniform_grid(0, 1, 0, 1, 0.5, boundaries={"west": [BC.water_level([1.0, 2.0, 3.0])]})
    with pytest.raises(InputError, match="3 values for 2 boundary cells"):
        SWESimulation(dom)
    with pytest.raises(InputError, match="shape"):
        SWESimulation(uniform_grid(0, 1, 0, 1, 0.5), initial=(np.zeros((3, 3)),) * 3)
    with pytest.raises(InputError, match="obstacles"):
        SWESimulation(uniform_grid(0, 1, 0, 1, 0.5), obstacles=np.zeros((3, 3), bool))


def test_level_time_series_fills_a_basin_at_the_prescribed_rate():
    # a 20 m basin fed through its west edge by a level rising 1 m -> 1.2 m over 200 s (slow: quasi-static)
    dom = uniform_grid(0, 20, 0, 2, 0.5, initial_surface=1.0, manning=0.03,
                       boundaries={"west": [BC.water_level([1.0, 1.2], times=[0.0, 200.0])]})
    sim = SWESimulation(dom)
    for t in (50.0, 100.0, 200.0):
        sim.advance_to(t)
        expected = 1.0 + 0.2 * t / 200.0
        assert abs(sim.depth.mean() - expected) < 0.01
    sim.advance_to(600.0)  # held at the last value; the seiche of the ramp stop decays
    assert abs(sim.depth.mean() - 1.2) < 2e-3


def test_level_varying_along_the_boundary_drives_a_cross_flow():
    prof = lambda s: 1.0 + 0.01 * s / 10.0      # 1 cm higher at the north end of the west edge
    dom = uniform_grid(0, 10, 0, 10, 0.5, initial_surface=1.0, manning=0.03,
                       boundaries={"west": [BC.water_level(prof)], "east": [BC.outflow()]})
    sim = SWESimulation(dom)
    sim.advance_to(60.0)
    assert np.all(np.isfinite(sim.depth))
    hv = sim.discharge[1]
    assert hv.mean() < 0  # flow from the high (north) end towards the south


def test_warm_start_obstacles_and_raised_bed():
    dom = channel(50, 50.0, lambda X, Y: np.where(X < 25, 2.0, 1.0), west=BC.wall(), east=BC.wall())
    sim = SWESimulation(dom)
    sim.advance_to(5.0)
    ds = sim.snapshot()
    # warm start from the snapshot reproduces the state
    again = SWESimulation(dom, initial=ds)
    np.testing.assert_allclose(again.depth, sim.depth, atol=1e-12)
    u0 = sim.velocity()[0]
    np.testing.assert_allclose(again.velocity()[0], u0, atol=1e-12)
    # an obstacle empties its cell and blocks the flow
    mask = np.zeros(dom.shape, bool)
    mask[0, 30] = True
    blocked = SWESimulation(dom, obstacles=mask, initial=ds)
    assert blocked.depth[0, 30] == 0
    # raising the bed keeps the water surface, so depth shrinks there
    raised = dom.with_raised_bed(mask, 1.5)
    r = SWESimulation(raised, initial=ds)
    surface = ds.depth.values[0, 30] + ds.bed_elevation.values[0, 30]
    assert r.depth[0, 30] == pytest.approx(max(surface - 1.5, 0.0))
    assert raised.bed[0, 30] == 1.5 and dom.bed[0, 30] == 0.0


def test_non_finite_initial_state_is_a_clear_error():
    dom = uniform_grid(0, 1, 0, 1, 0.5)
    with pytest.raises(InputError, match="initial depth"):
        SWESimulation(dom, initial=(np.full((2, 2), np.nan), np.zeros((2, 2)), np.zeros((2, 2))))
    assert issubclass(PhysicsError, RuntimeError)


def test_snapshot_output_is_schema_valid_with_derived_fields_and_history():
    dom = channel(40, 40.0, 1.0, bed=lambda X, Y: -0.001 * X, west=BC.inflow(1.0), east=BC.outflow(), manning=0.03)
    solver = solvers.create("swe", tolerance=1e-3, t_max=300.0)
    ds = solver.solve(dom)
    validate(ds, "snapshot_grid")
    for name in ("speed", "froude_number", "unit_discharge", "total_head", "bed_shear_stress", "incipient_grain_size"):
        assert name in ds and ds[name].attrs["units"]
    assert ds.sizes["convergence_check"] == len(solver.last.history.time) > 0
    h, u, n = ds.depth.values, ds.u.values, 0.03
    wet = h > 0
    np.testing.assert_allclose(ds.speed.values, np.hypot(u, ds.v.values))
    np.testing.assert_allclose(ds.froude_number.values[wet], np.abs(u[wet]) / np.sqrt(9.81 * h[wet]))
    tau = 1000 * 9.81 * n**2 * u**2 / h ** (1 / 3)
    np.testing.assert_allclose(ds.bed_shear_stress.values[wet], tau[wet])
    np.testing.assert_allclose(ds.incipient_grain_size.values[wet], tau[wet] / (1.65 * 1000 * 9.81 * 0.047))
    np.testing.assert_allclose(ds.total_head.values[wet], (ds.bed_elevation.values + h + u**2 / (2 * 9.81))[wet])
    assert ds.attrs["solver"] == "swe" and ds.attrs["steady_state"] in (0, 1)


def test_derived_fields_hand_values():
    # Manning: h = 1 m, |u| = 2 m/s, n = 0.025 -> tau = 1000 * 9.81 * 0.025^2 * 4 = 24.525 Pa
    tau = derived.bed_shear_stress(np.array([1.0, 0.0]), np.array([2.0, 5.0]), np.zeros(2), 0.025)
    assert tau[0] == pytest.approx(24.525) and tau[1] == 0.0
    # Shields: D = tau / ((G_S - 1) rho g tau*_c) = 24.525 / (1.65 * 9810 * 0.047) = 3.22 mm
    assert derived.incipient_grain_size(24.525) == pytest.approx(24.525 / (1.65 * 9810 * 0.047))
    assert derived.froude(np.array([4.0]), np.array([2 * math.sqrt(9.81)]), np.zeros(1))[0] == pytest.approx(1.0)
    with pytest.raises(InputError):
        derived.incipient_grain_size(1.0, specific_gravity=0.9)


def test_registry_has_swe_and_snapshot_and_third_party_solvers_plug_in():
    assert {"swe", "snapshot"} <= set(solvers.available())
    assert isinstance(solvers.create("swe"), HydroSolver)

    class Still:
        def solve(self, domain, obstacles=None, initial=None):
            return "still water"

    solvers.register("still-test", Still)
    assert solvers.create("still-test").solve(None) == "still water"
    with pytest.raises(InputError, match="unknown hydrodynamic solver"):
        solvers.create("adh-live")


def test_snapshot_solver_serves_a_sequence_one_per_cycle(tmp_path):
    dom = uniform_grid(0, 4, 0, 2, 1.0, initial_surface=1.0)
    first = SWESimulation(dom).snapshot()
    second = first.copy(deep=True)
    second["depth"] = second.depth * 2
    path = tmp_path / "b.nc"
    second.to_netcdf(path)
    s = solvers.create("snapshot", snapshots=[first, path])
    assert s.solve(dom) is first
    np.testing.assert_allclose(s.solve(dom).depth.values, 2.0)
    with pytest.warns(UserWarning, match="reuses the last"):
        s.solve(dom)
    timed = xr.concat([first, second], dim="time")
    s2 = SnapshotSolver(timed)
    assert float(s2.solve().depth.max()) == 1.0 and float(s2.solve().depth.max()) == 2.0
    with pytest.raises(InputError):
        SnapshotSolver()


def test_typical_breach_terrain():
    scene = typical_breach()
    dom = breach_domain(scene, 4.0)
    assert dom.dx == pytest.approx(4.0, rel=0.01) and dom.dy == pytest.approx(4.0, rel=0.01)
    assert dom.x[0] - dom.dx / 2 == pytest.approx(-(914.6 + 30.5))
    assert dom.y[0] - dom.dy / 2 == pytest.approx(-385.0) and dom.y[-1] + dom.dy / 2 == pytest.approx(488.0)
    X, Y = np.meshgrid([300.0, 0.0, 300.0, 0.0, 0.0], [0.0, 0.0, 10.0, -400.0, 488.0])
    z = levee_bed(scene, np.array([300.0, 0.0, 300.0, 0.0, 0.0]), np.array([0.0, 0.0, 10.0, -100.0, 488.0]))
    assert z[0] == pytest.approx(38.1)                     # levee crest outside the breach
    assert z[1] == pytest.approx(30.5)                     # breach floor on the ground
    assert z[2] == pytest.approx(30.5 + 7.6 - (10.0 - 1.5) / 4.0)   # protected slope 1V:4H
    assert z[3] == pytest.approx(30.5)                     # flood channel
    toe = 1.5 + 7.6 * 4
    assert z[4] == pytest.approx(30.5 - (488.0 - toe) / 4800.0)
    # the intact levee is a no-flow boundary, the breach is open, every column of the levee is blocked
    jc = int(np.argmin(np.abs(dom.y)))
    open_cols = ~dom.obstacle[jc]
    assert np.abs(dom.x[open_cols]).max() <= 30.5 + 1e-9 and open_cols.sum() >= 14
    # flood source: level at the upstream end = flood elevation, falling 0.09 m along 1890 m
    lev = dom.boundaries["south"][0].level
    assert lev(np.array([dom.x[0] - dom.dx / 2]))[0] == pytest.approx(38.1)
    assert lev(np.array([dom.x[0] - dom.dx / 2 + 1890.0]))[0] == pytest.approx(38.01)
    with pytest.raises(InputError):
        breach_domain(scene, 500.0)


def test_steady_state_monitor_region_must_not_be_empty():
    sim = SWESimulation(uniform_grid(0, 2, 0, 2, 1.0, initial_surface=1.0))
    with pytest.raises(InputError, match="empty"):
        sim.run_to_steady(region=np.zeros((2, 2), bool))
    hist = sim.run_to_steady(tolerance=1e-6, t_max=5.0, region=np.eye(2, dtype=bool))
    assert hist.converged  # still water: nothing changes


def test_cli_solve_writes_snapshot_and_png(tmp_path):
    from typer.testing import CliRunner

    from breachflow.cli import app

    nc, png = tmp_path / "s" / "snapshot.nc", tmp_path / "s.png"
    res = CliRunner().invoke(app, ["solve", "--resolution", "30 m", "--t-max", "40 s", "--output", str(nc.parent), "--png", str(png)])
    assert res.exit_code == 0, res.output
    assert "Ritter" in res.output and "peak speed" in res.output
    ds = xr.open_dataset(nc)
    validate(ds, "snapshot_grid")
    assert float(ds.speed.max()) > 1.0 and png.stat().st_size > 10_000
    assert not list(tmp_path.glob(".*.tmp"))
    res = CliRunner().invoke(app, ["solve", "nowhere"])
    assert res.exit_code != 0


def test_cli_solve_the_demo_breach(tmp_path):
    """``breachflow solve demo_breach``: the scaled breach of the default run (the regional model the
    README's nested workflow exports to ADH / HEC-RAS)."""
    from typer.testing import CliRunner

    from breachflow.cli import app

    nc = tmp_path / "demo" / "snapshot.nc"
    res = CliRunner().invoke(app, ["solve", "demo_breach", "--resolution", "3 m", "--t-max", "20 s", "-o", str(nc.parent)])
    assert res.exit_code == 0, res.output
    assert "report (ADH)" not in res.output  # the report's ADH figure belongs to the typical breach only
    ds = xr.open_dataset(nc)
    assert ds.sizes["x"] * 3.0 == pytest.approx(72.0, abs=3.0)  # 2 x 30 m of levee + the 12 m breach
    assert float(ds.water_surface.max()) == pytest.approx(3.0, abs=0.05)  # flood level at the 3 m crest
