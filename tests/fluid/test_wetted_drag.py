"""The profile factor of the drag over a mass's wetted height (fluid/profile.py ``drag_factor``), against
independent references: scipy quadrature over the chord and over the disc, closed forms and limits."""
import math

import numpy as np
import pytest
from scipy.integrate import dblquad, quad

from breachflow.fluid.profile import (DRAG_POINTS, PROFILES, chord_node, drag_factor, drag_factors, factors,
                                      profile_factor, wetted_factor)


def quad_factor(name, z_lo, z_hi, zc, r, h, ks):
    """sign(m) sqrt|m|, m = int f|f| w dz / int w dz over z_lo..z_hi, w the chord 2 sqrt(r^2 - (z - zc)^2)."""
    code = PROFILES[name]
    w = lambda z: 2.0 * math.sqrt(max(r * r - (z - zc) ** 2, 0.0))  # noqa: E731
    g = lambda z: (lambda f: f * abs(f))(profile_factor(code, z, h, ks)) * w(z)  # noqa: E731
    pts = [p for p in (ks / 30.0, h) if z_lo < p < z_hi] or None
    num = quad(g, z_lo, z_hi, points=pts, limit=400, epsabs=0.0, epsrel=1e-11)[0]
    den = quad(w, z_lo, z_hi, limit=400, epsabs=0.0, epsrel=1e-11)[0]
    m = num / den
    return math.copysign(math.sqrt(abs(m)), m)


def sweep(seed=1, n=150):
    """(zc, r, h, ks) over the phases a mass goes through: resting on / pressed into the bed, straddling the
    surface (centre above and below it), inside the water, anywhere (also above the water)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        h = rng.uniform(0.3, 10.0)
        r = rng.uniform(0.05, 0.5) if k % 2 else rng.uniform(0.5, 3.0)
        ks = (0.066, rng.uniform(0.005, 0.5), 2.0 * r)[k % 3]
        mode = (k // 3) % 4
        if mode == 0:
            zc = r - rng.uniform(0.0, 0.02 * r)
        elif mode == 1:
            zc = h + rng.uniform(-r, r)
        elif mode == 2:
            zc = rng.uniform(r, max(r, h - r))
        else:
            zc = rng.uniform(-0.5 * r, h + 0.9 * r)
        out.append((zc, r, h, ks))
    return out


@pytest.mark.parametrize("name", ["log", "power"])
def test_factor_matches_quadrature_over_a_sweep_of_phases(name):
    """DRAG_POINTS Gauss–Legendre points keep the factor within 1e-3 of the adaptive quadrature at every
    phase of the sweep (the log law's z0 cut and the power law's bed singularity included)."""
    errs = []
    for zc, r, h, ks in sweep():
        lo, hi = max(0.0, zc - r), min(h, zc + r)
        got = float(drag_factors(name, zc, r, h, ks))
        if hi <= lo:  # nothing wetted: the point value
            assert got == float(factors(name, zc, h, ks))
            continue
        ref = quad_factor(name, lo, hi, zc, r, h, ks)
        assert got == pytest.approx(ref, rel=1e-3, abs=1e-6), (zc, r, h, ks)
        if ref > 1e-3:
            errs.append(abs(got / ref - 1.0))
    assert DRAG_POINTS == 8 and len(errs) > 100
    assert max(errs) < 1e-3 and np.median(errs) < 1e-5


@pytest.mark.parametrize("name", ["log", "power"])
@pytest.mark.parametrize("z_hi_over_h", [1.2, 1.6])
def test_explicit_bounds_above_the_surface_hold_the_surface_value(name, z_hi_over_h):
    """``drag_factor`` with a wetted part reaching above the surface uses the profile held at its surface value
    (the kink at the surface is inside the rule's interval here: within the sweep's 1e-3)."""
    h, ks, r = 2.0, 0.066, 1.5
    zc = z_hi_over_h * h - r
    got = drag_factor(PROFILES[name], 0.5, z_hi_over_h * h, zc, r, h, ks)
    assert got == pytest.approx(quad_factor(name, 0.5, z_hi_over_h * h, zc, r, h, ks), rel=1e-3)


def test_factor_is_the_disc_average_of_u_abs_u():
    """Independent of the chord form: the mean of f|f| over the wetted part of the disc by dblquad."""
    for name in ("log", "power"):
        for zc, r, h in [(1.0, 1.0, 1.5), (2.0, 2.0, 3.0), (3.2, 1.0, 3.0), (0.99, 1.0, 8.0)]:
            code = PROFILES[name]
            lo, hi = max(0.0, zc - r), min(h, zc + r)
            half = lambda z: math.sqrt(max(r * r - (z - zc) ** 2, 0.0))  # noqa: E731
            num = dblquad(lambda y, z: profile_factor(code, z, h, 0.066) ** 2, lo, hi,
                          lambda z: -half(z), half, epsabs=1e-10, epsrel=1e-9)[0]
            den = dblquad(lambda y, z: 1.0, lo, hi, lambda z: -half(z), half)[0]
            assert wetted_factor(code, zc, r, h, 0.066) == pytest.approx(math.sqrt(num / den), rel=1e-3)


def test_uniform_profile_and_no_log_layer_give_exactly_one():
    for zc, r, h, ks in sweep(seed=2, n=40):
        assert wetted_factor(0, zc, r, h, ks) == 1.0
        assert wetted_factor(1, zc, r, h, 30.0 * h) == 1.0  # ln(30 h/k_s) - 1 <= 1: no log layer
        assert wetted_factor(1, zc, r, 0.0, ks) == 1.0 and wetted_factor(2, zc, r, -1.0, ks) == 1.0  # dry


@pytest.mark.parametrize("name", ["log", "power"])
def test_tiny_mass_feels_the_point_value(name):
    for zc in (0.01, 0.3, 1.7, 2.9):
        point = float(factors(name, zc, 3.0, 0.066))
        assert float(drag_factors(name, zc, 1e-6, 3.0, 0.066)) == pytest.approx(point, rel=1e-9)


@pytest.mark.parametrize("a,b", [(1.0, 0.0), (0.7, 0.3), (0.2, -0.9), (2.0, 1.5)])
def test_the_rule_integrates_a_linear_profile_over_the_disc(a, b):
    """Fully submerged, f = a + b x (x = (z - z_c)/r): the mean of f^2 over the disc is a^2 + b^2/4 (second
    moment of the unit disc pi/4); a partly wetted disc against quad. The rule's integrand carries
    sqrt(4 - t^2), so it is not exact for polynomials: 1e-8 here."""
    nodes = [chord_node(k, -1.0, 1.0) for k in range(DRAG_POINTS)]
    mean = sum(w * (a + b * x) ** 2 for x, w in nodes) / math.pi
    assert mean == pytest.approx(a * a + b * b / 4.0, abs=1e-8 * (a * a + b * b))
    x_hi = 0.35
    t_hi = 2.0 * math.sin(math.asin(x_hi) / 3.0)
    part = sum(w * (a + b * x) ** 2 for x, w in (chord_node(k, -1.0, t_hi) for k in range(DRAG_POINTS)))
    ref = quad(lambda x: (a + b * x) ** 2 * 2.0 * math.sqrt(1.0 - x * x), -1.0, x_hi, epsabs=0, epsrel=1e-12)[0]
    assert part == pytest.approx(ref, rel=1e-8)


@pytest.mark.parametrize("name", ["log", "power"])
def test_large_masses_in_shallow_water_feel_less_than_their_centre_value(name):
    """On the bed with h/D <= 1 (the closure's rock masses): the centre value overstates the drag (f^2)."""
    for D, h in [(2.0, 2.0), (4.0, 3.0), (5.0, 4.0), (3.0, 2.5)]:
        r = 0.5 * D
        f_c = float(factors(name, r, h, 0.066))
        f_w = float(drag_factors(name, r, r, h, 0.066))
        assert f_w < f_c
        assert f_w == pytest.approx(quad_factor(name, 0.0, min(h, D), r, r, h, 0.066), rel=1e-3)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("name", ["log", "power"])
def test_drag_on_resting_masses_over_a_sweep_of_heights(compiled, name):
    """FluidForces (fused kernel and step path) on a mass at rest in a grid field, drag law with constant C_D:
    ``phi 1/2 rho C_D A (U F)^2`` with F from quad over the wetted chord, for centres pressed into the bed, on
    it, inside the water, just below, at and above the surface (partly emerged) and a sliver in the water."""
    from breachflow.dem.state import ParticleState
    from breachflow.fluid.drag import get_drag_law
    from breachflow.fluid.forces import FluidForces
    from breachflow.hydro.snapshot import grid_snapshot

    x = np.arange(-20.0, 20.01, 1.0)
    X, Y = np.meshgrid(x, x)
    bed = 1e-3 * X  # non-uniform: the closure's path (fused kernel)
    h, U, D, ks = 3.0, 4.0, 2.4, 0.066
    snap = grid_snapshot(x, x, bed, h - bed, U * (1.0 + 1e-3 * X), np.zeros(X.shape))  # U at x = 0
    ff = FluidForces(snap, velocity_profile=name, roughness=ks, drag_law="constant", air=None, xi=0.0,
                     torque=False, compiled=compiled)
    assert (ff._fused is not None) is compiled
    cd = float(get_drag_law("constant").cd(1e5))
    a = 0.5 * D
    cap = lambda t: math.pi * t * t * (3 * a - t) / 3  # noqa: E731
    for zc in (a - 0.03, a, 1.5, h - a, h - 0.3, h, h + 0.4, h + a - 0.1):
        st = ParticleState.spheres(np.array([[0.0, 0.0, zc]]), a)
        f = np.zeros((1, 3))
        ff.accumulate(st, st.pos, st.vel, st.omega, 0.0, f, np.zeros((1, 3)))
        lo, hi = max(0.0, zc - a), min(h, zc + a)
        F = quad_factor(name, lo, hi, zc, a, h, ks)
        phi = (cap(min(max(h - (zc - a), 0.0), D)) - cap(min(max(-(zc - a), 0.0), D))) / (4 / 3 * math.pi * a ** 3)
        drag = phi * 0.5 * 1000.0 * cd * math.pi * a * a * (U * F) ** 2
        assert f[0, 0] == pytest.approx(drag, rel=2e-3), zc


def _rolling_threshold(D, h, ks, rho=2650.0, mu_r=0.3):
    """Depth-averaged speed U at which a lone sphere resting on a flat bed in water h rolls, by hand: the drag
    phi 1/2 rho_w C_D(Re) A (U F)^2 (F the wetted log-law factor by quad, Re = U F D / nu) equals mu_r times
    the submerged weight (rho_s V - rho_w phi V) g (the rolling-resistance moment mu_r R F_N against F_D R);
    phi the submerged volume fraction (a cap for h < D)."""
    from breachflow.fluid.drag import get_drag_law

    a = 0.5 * D
    F = quad_factor("log", 0.0, min(h, D), a, a, h, ks)
    s = min(h, D)
    phi = math.pi * s * s * (3 * a - s) / 3 / (4 / 3 * math.pi * a ** 3)
    vol, area = 4 / 3 * math.pi * a ** 3, math.pi * a * a
    weight = mu_r * 9.80665 * (rho - 1000.0 * phi) * vol
    u = 5.0
    for _ in range(100):
        u = math.sqrt(weight / (phi * 0.5 * 1000.0 * float(get_drag_law("report").cd(u * D / 1e-6)) * area))
    return u / F


@pytest.mark.parametrize("ratio,rolls", [(0.95, False), (1.05, True)])
def test_a_partly_emerged_sphere_on_the_bed_rolls_at_the_wetted_average_threshold(ratio, rolls):
    """The DEM with the log profile (the closure's default) agrees with the hand threshold built on the wetted
    average: a 2 m sphere on a flat bed in 1 m of water (h/D = 0.5) stays at 0.95 U_c and rolls at 1.05 U_c.
    With the centre value (the old model) the threshold was 11 % lower, so it rolled at 0.95 U_c."""
    from breachflow.dem import DemSimulation, HeightField, Material
    from breachflow.fluid.field import UniformWater
    from breachflow.fluid.forces import FluidForces

    D, h, ks = 2.0, 1.0, 0.066
    u_c = _rolling_threshold(D, h, ks)
    mat = Material(density=2650.0, kn=2.0e7, friction=0.6, rolling_friction=0.3).with_restitution(
        0.3, 2650.0 * math.pi / 6 * D ** 3)
    x = np.linspace(-50.0, 50.0, 11)
    bed = HeightField(x, x, np.zeros((11, 11)), mat)
    water = UniformWater(surface=h, u=ratio * u_c, v=0.0, bed=0.0)
    model = FluidForces(water, air=None, velocity_profile="log", roughness=ks)
    sim = DemSimulation(boundaries=[bed], models=[model], sleeping=False, static_models=True)
    sim.add_particles(np.array([[0.0, 0.0, 0.5 * D - 2e-3]]), 0.5 * D, mat)
    sim.step(int(math.ceil(8.0 / sim.dt)))
    moved = float(np.hypot(*sim.state.pos[0, :2]))
    assert (moved > 0.5 * D) is rolls, moved
