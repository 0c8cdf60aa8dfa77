"""Vertical velocity profiles, the stone-size estimate and the DEM stone stability vs Izbash/Shields."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from breachflow.errors import InputError
from breachflow.fluid.field import UniformWater
from breachflow.fluid.forces import FluidForces
from breachflow.fluid.profile import factors, profile_code, roughness_from_manning
from breachflow.scenario.stone import (fill_volume, izbash_diameter, izbash_velocity, shields_diameter,
                                       shields_velocity, stone_size)
from breachflow.scenario.toml import scenario_with


@pytest.mark.parametrize("name", ["log", "power", "uniform"])
@pytest.mark.parametrize("h,ks", [(1.0, 0.066), (3.0, 0.5), (10.0, 0.02), (2.0, 1.0)])
def test_profile_depth_average_is_one(name, h, ks):
    """The profile is consistent with the depth-averaged velocity: (1/h) int_0^h u(z)/U dz = 1
    (log law: integrated from z0 = k_s/30, the bottom of the log layer, as in its derivation)."""
    z0 = ks / 30.0 if name == "log" else 0.0
    f = lambda z: float(factors(name, z, h, ks))  # noqa: E731
    mean = quad(f, z0, h, limit=200)[0] / h
    # the log law's depth mean over z0..h equals 1 - z0/h * (...) -> within z0/h of 1
    assert mean == pytest.approx(1.0, abs=max(1e-6, 2 * z0 / h))


def test_log_law_shape_and_strickler():
    # u(z2)/u(z1) = ln(z2/z0)/ln(z1/z0) for the rough log law
    h, ks = 5.0, 0.3
    z0 = ks / 30
    r = factors("log", 2.0, h, ks) / factors("log", 0.5, h, ks)
    assert r == pytest.approx(math.log(2.0 / z0) / math.log(0.5 / z0), rel=1e-12)
    # the power law's surface value 8/7 and 1/7 exponent
    assert factors("power", h, h, ks) == pytest.approx(8 / 7)
    assert factors("power", h / 2, h, ks) / factors("power", h, h, ks) == pytest.approx(0.5 ** (1 / 7))
    # Manning–Strickler (Parker): n = k_s^(1/6) / (8.1 sqrt(g))
    n = 0.025
    ks = roughness_from_manning(n)
    assert ks ** (1 / 6) / (8.1 * math.sqrt(9.80665)) == pytest.approx(n, rel=1e-12)
    # Manning's U for a wide channel equals the log law's depth mean with that k_s within ~10 % over h = 1..10 m
    for h in (1.0, 3.0, 10.0):
        S = 1e-4
        u_manning = h ** (2 / 3) * math.sqrt(S) / n
        ustar = math.sqrt(9.80665 * h * S)
        u_log = ustar / 0.41 * (math.log(30 * h / ks) - 1)
        assert u_log == pytest.approx(u_manning, rel=0.1)
    with pytest.raises(InputError):
        profile_code("parabolic")


def test_forces_use_the_profile_at_the_centre_height():
    """A sphere held still near the bed feels the profile's velocity: drag ratio = factor^2 (same C_D,
    same Reynolds number when the velocity is scaled to keep it)."""
    U, h, ks = 2.0, 4.0, 0.2
    z = 0.3
    f = float(factors("log", z, h, ks))
    assert 0 < f < 1
    water_log = UniformWater(surface=h, u=U, bed=0.0)
    water_uni = UniformWater(surface=h, u=U * f, bed=0.0)
    out = []
    for water, prof in ((water_log, "log"), (water_uni, "uniform")):
        ff = FluidForces(water, drag_law="constant", velocity_profile=prof, roughness=ks, air=None, torque=False)

        class S:  # minimal state
            radius = np.array([0.1])
            pos = np.array([[0.0, 0.0, z]])
        force = np.zeros((1, 3))
        ff.accumulate(S, S.pos, np.zeros((1, 3)), np.zeros((1, 3)), 0.0, force, np.zeros((1, 3)))
        out.append(force[0].copy())
    np.testing.assert_allclose(out[0], out[1], rtol=1e-12)
    assert out[0][0] > 0


def test_stone_size_izbash_shields_and_volume():
    # Izbash: D = U^2 / (2 g Delta C^2), the inverse of the critical velocity
    for U in (1.0, 3.0, 6.0):
        D = izbash_diameter(U)
        assert izbash_velocity(D) == pytest.approx(U, rel=1e-12)
        assert izbash_diameter(U, placement="embedded") == pytest.approx(D * (0.86 / 1.2) ** 2)
    # Shields root
    D = shields_diameter(4.0, 3.0)
    assert shields_velocity(D, 3.0) == pytest.approx(4.0, rel=1e-9)
    # trapezoid volume: vertical walls -> cross-section (b + m H) H times B
    assert fill_volume(12.0, 3.0, 2.0, 1.5, 0.0) == pytest.approx((2.0 + 1.5 * 3.0) * 3.0 * 12.0)
    # sloping walls: compare with numerical integration
    num = quad(lambda z: (2.0 + 2 * 1.5 * (3.0 - z)) * (12.0 + 2 * 0.5 * z), 0, 3.0)[0]
    assert fill_volume(12.0, 3.0, 2.0, 1.5, 0.5) == pytest.approx(num, rel=1e-12)
    e = stone_size("4 m/s", "3 m", "12 m", porosity=0.4)
    assert e.design_diameter == pytest.approx(max(e.d_izbash_exposed, e.d_shields))
    assert e.tonnage == pytest.approx(2650 * 0.6 * e.bulk_volume / 1000)
    with pytest.raises(InputError):
        stone_size("4 m/s", "3 m", "12 m", density="900 kg/m^3")
    with pytest.raises(InputError):
        stone_size("4 m/s", "3 kg", "12 m")


def test_stone_size_cli():
    from typer.testing import CliRunner

    from breachflow.cli import app

    r = CliRunner().invoke(app, ["stone-size", "--velocity", "4 m/s", "--depth", "3 m", "--breach-length", "12 m"])
    assert r.exit_code == 0, r.output
    assert "tonnage" in r.output and "Izbash" in r.output


# --- stone stability from the DEM + fluid forces -------------------------------------------------------
# Bands measured with `python pipelines/stone_stability.py docs` (README): the DEM has no lift force, so
# stones are somewhat more stable than Izbash's exposed stones.


IZB = lambda D: math.sqrt(2 * 9.80665 * 1.65 * D)  # noqa: E731


@pytest.mark.parametrize("D", [0.1, 0.2, 0.5, 1.0, 2.0])
def test_critical_velocity_uniform_profile_between_izbash_exposed_and_embedded(D):
    """Rough-stone drag (Clift–Gauvin, no drag crisis), uniform profile: U_c / sqrt(2 g Delta D) lies between
    Izbash's exposed (0.86) and embedded (1.2) coefficients (measured 0.905–0.952)."""
    from breachflow.studies.stability import critical_velocity

    c = critical_velocity(D, 3.0 if D <= 0.5 else 10.0, velocity_profile="uniform", drag_law="clift_gauvin") / IZB(D)
    assert 0.86 <= c <= 1.2, c


@pytest.mark.parametrize("D", [0.1, 0.2, 0.5, 2.0])
def test_critical_velocity_report_drag_law(D):
    """The default (report) drag law has the smooth-sphere drag crisis (C_D ~ 0.1 near R ~ 4e5): stones of
    0.2–0.5 m are harder to move than Izbash says. Band measured 0.92–1.80 (README)."""
    from breachflow.studies.stability import critical_velocity

    c = critical_velocity(D, 3.0 if D <= 0.5 else 10.0, velocity_profile="uniform") / IZB(D)
    assert 0.86 <= c <= 1.9, c


@pytest.mark.parametrize("D,h", [(0.1, 1.0), (0.1, 10.0), (0.5, 3.0), (1.0, 3.0), (2.0, 10.0)])
def test_critical_velocity_log_profile_follows_shields(D, h):
    """Log profile (Clift–Gauvin drag): U_c / U_Shields(theta_c = 0.047, k_s = 2 D) in 1.0–1.4 for
    D = 0.1–2 m, h = 1–10 m (measured 1.18–1.24: the model has no lift force).

    Izbash's coefficient refers to the velocity near the stone: with u_b = u(z = D) the log profile's
    critical u_b / sqrt(2 g Delta D) lies in 1.1–1.35 at every depth (measured 1.19–1.26, about Izbash's
    embedded 1.2); the depth-averaged U_c / sqrt(2 g Delta D) grows with h/D and is in 1.4–1.95 where
    h/D is in Izbash's range 5–10 (measured 1.48–1.85; 1.09–2.78 over h/D = 2–100)."""
    from breachflow.studies.stability import critical_velocity, near_bed_velocity

    uc = critical_velocity(D, h, velocity_profile="log", drag_law="clift_gauvin")
    ratio = uc / shields_velocity(D, h)
    assert 1.0 <= ratio <= 1.4, ratio
    c_b = near_bed_velocity(uc, D, h, velocity_profile="log") / IZB(D)
    assert 1.1 <= c_b <= 1.35, c_b
    if 5.0 <= h / D <= 10.0:
        assert 1.4 <= uc / IZB(D) <= 1.95, uc / IZB(D)


@pytest.mark.parametrize("D,h", [(0.2, 1.0), (2.0, 10.0)])
def test_critical_velocity_power_profile_near_bed_is_izbash(D, h):
    """Power (1/7) profile, Clift–Gauvin drag: the velocity at z = D at the critical U_c lies between
    Izbash's exposed and embedded coefficients, 0.86–1.2 sqrt(2 g Delta D) (measured 0.99–1.05 over
    D = 0.1–2 m, h = 1–10 m)."""
    from breachflow.studies.stability import critical_velocity, near_bed_velocity

    uc = critical_velocity(D, h, velocity_profile="power", drag_law="clift_gauvin")
    c_b = near_bed_velocity(uc, D, h, velocity_profile="power") / IZB(D)
    assert 0.86 <= c_b <= 1.2, c_b


def test_near_bed_velocity_is_the_profile_at_one_diameter():
    """u_b = U u(z = D)/U of the profile with k_s = 2 D: closed forms of the log and power laws."""
    from breachflow.studies.stability import near_bed_velocity

    D, h, U = 0.5, 4.0, 3.0
    assert near_bed_velocity(U, D, h, velocity_profile="log") == pytest.approx(
        U * math.log(30 * D / (2 * D)) / (math.log(30 * h / (2 * D)) - 1), rel=1e-12)
    assert near_bed_velocity(U, D, h, velocity_profile="power") == pytest.approx(U * 8 / 7 * (D / h) ** (1 / 7),
                                                                                 rel=1e-12)
    assert near_bed_velocity(U, D, h, velocity_profile="uniform") == U


def test_critical_velocity_grows_with_depth_only_with_a_profile():
    from breachflow.studies.stability import critical_velocity

    u1, u10 = (critical_velocity(0.2, h, velocity_profile="uniform") for h in (1.0, 10.0))
    assert u10 == pytest.approx(u1, rel=0.02)
    l1, l10 = (critical_velocity(0.2, h, velocity_profile="log") for h in (1.0, 10.0))
    # Shields/log law: U_c(10 m)/U_c(1 m) = (ln(300/0.4) - 1)/(ln(30/0.4) - 1)
    expect = (math.log(30 * 10 / 0.4) - 1) / (math.log(30 * 1 / 0.4) - 1)
    assert l10 / l1 == pytest.approx(expect, rel=0.05)


def test_scenario_key_reaches_the_fluid_forces():
    from breachflow.cycle.config import closure_setup
    from breachflow.scenario.config import parse_scenario

    sc = parse_scenario('[fluid]\nvelocity_profile = "log"\nroughness = "0.1 m"\n')
    setup = closure_setup(sc)
    assert setup.dem.velocity_profile == "log" and setup.dem.roughness == pytest.approx(0.1)
    from breachflow.errors import BreachflowError

    with pytest.raises(BreachflowError, match="velocity_profile"):
        parse_scenario('[fluid]\nvelocity_profile = "cubic"\n')


def test_closure_cycle_runs_with_the_log_profile(tmp_path):
    """The `[fluid] velocity_profile` key reaches the closure run's force model: a cycle with the log law
    runs, and the force model the DEM uses carries the profile and the roughness from Manning's n."""
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.driver import ClosureRun
    from breachflow.scenario.config import parse_scenario

    ci = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()
    text = scenario_with(ci, {"scenario.name": None, "dem.record_interval": None, "placement.positions": None,
                              "criteria.mode": None, "criteria.max_cycles": 1, "closure.remap": None, "closure.seed": None,
                              "fluid.velocity_profile": "log"})
    run = ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "log", text)
    (rep,) = run.run()
    assert rep.masses == 3
    fluid = run.dem.live[1].models[0]
    assert fluid.velocity_profile == "log"
    assert fluid.roughness == pytest.approx(roughness_from_manning(0.025))


def test_default_run_uses_the_log_profile():
    """The default velocity profile of a closure run (embedded scenario, or a file without the key) is the
    log law."""
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.main import default_scenario_text
    from breachflow.scenario.config import parse_scenario

    setup = closure_setup(parse_scenario(default_scenario_text()))
    assert setup.dem.velocity_profile == "log"
    assert closure_setup(parse_scenario("")).dem.velocity_profile == "log"


@pytest.mark.parametrize("h_over_D", [3.0, 10.0, 100.0])
def test_area_averaged_drag_velocity_of_the_bed_stone_is_near_the_centre_value(h_over_D):
    """Drag from the mean u|u| over the stone's projected area (Wiberg & Smith 1987) instead of u at the
    centre: for the bed stone of fluid.stability (centre sqrt(2/3) D above the bed-sphere centres, bed level
    0.2 D below their crests, k_s = 2 D) the effective log-law velocity is 0.97 x the centre value (the
    lowest ~5 % of the stone lies below z0 = k_s/30), so the centre value the model uses is not what makes
    log-profile stones harder to move than Izbash (README)."""
    D, a = 1.0, 0.5
    h, ks = h_over_D * D, 2.0 * D
    zc = math.sqrt(2.0 / 3.0) * D - 0.3 * D
    f = lambda z: float(factors("log", z, h, ks))  # noqa: E731
    w = lambda z: 2.0 * math.sqrt(max(a * a - (z - zc) ** 2, 0.0))  # noqa: E731
    lo, hi = zc - a, min(zc + a, h)
    mean_sq = quad(lambda z: f(z) ** 2 * w(z), lo, hi, points=[ks / 30], limit=200)[0] / quad(w, lo, hi)[0]
    ratio = math.sqrt(mean_sq) / f(zc)
    assert 0.96 <= ratio <= 0.98, ratio


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("where,zc,D", [("floor, h/D = 1.5", 1.0, 2.0), ("floor, h/D = 0.75 (emergent)", 2.0, 4.0),
                                         ("on the pile, 0.5 m of water over it", 3.0, 1.0)])
def test_drag_on_a_resting_mass_matches_the_log_law_by_hand(compiled, where, zc, D):
    """Drag on a mass at rest in a grid field (as the closure's DEM sees it, fused kernel and step path)
    against a hand calculation: log law ``u(z) = (u*/kappa) ln(30 z/k_s)`` with ``u*`` matched to the
    depth mean ``U`` over ``z0..h``, at the mass's centre height above the local bed (the raised pile top
    on the pile, clipped to the surface), times the drag law and the submerged fraction. On the pile the
    height and the depth are measured from the pile's top (2.5 m), not from the terrain."""
    from breachflow.dem.state import ParticleState
    from breachflow.fluid.drag import DRAG_LAWS
    from breachflow.field.snapshot import grid_snapshot

    x = np.arange(-20.0, 20.01, 1.0)
    X, Y = np.meshgrid(x, x)
    on_pile = where.startswith("on the pile")
    bed = np.where((np.abs(X) <= 8) & (np.abs(Y) <= 8), 2.5, 0.0) if on_pile else np.zeros(X.shape)
    bed = bed + 1e-3 * X  # a non-uniform field: the closure's path
    h = 3.0 - bed
    U = 5.0
    snap = grid_snapshot(x, x, bed, h, np.full(X.shape, U), np.zeros(X.shape))
    ks = float(roughness_from_manning(0.025))
    ff = FluidForces(snap, velocity_profile="log", manning=0.025, air=None, xi=0.0, torque=False, compiled=compiled)
    st = ParticleState.spheres(np.array([[0.0, 0.0, zc]]), 0.5 * D)
    f = np.zeros((1, 3))
    ff.accumulate(st, st.pos, st.vel, st.omega, 0.0, f, np.zeros((1, 3)))
    # by hand
    b0, h0 = (2.5, 0.5) if on_pile else (0.0, 3.0)
    kappa = 0.41
    ustar = U * kappa / (math.log(30 * h0 / ks) - 1.0)   # mean of (u*/kappa) ln(z/z0) over z0..h is U
    u = ustar / kappa * math.log(30 * min(zc - b0, h0) / ks)
    a = 0.5 * D
    cap = lambda t: math.pi * t * t * (3 * a - t) / 3  # noqa: E731
    phi = (cap(min(max(b0 + h0 - (zc - a), 0.0), D)) - cap(min(max(b0 - (zc - a), 0.0), D))) / (4 / 3 * math.pi * a ** 3)
    assert 0 < phi <= 1
    cd = float(DRAG_LAWS.create("report").cd(u * D / 1e-6))
    drag = phi * 0.5 * 1000.0 * cd * math.pi * D * D / 4 * u * u
    assert f[0, 0] == pytest.approx(drag, rel=1e-9), where
