"""Buoyancy with the spherical cap, drag, apparent mass, convective term and fluid torque (docs/theory.md, *Fluid forces on a mass*)."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from breachflow.dem.state import Material, ParticleState
from breachflow.errors import PhysicsError
from breachflow.fluid.field import UniformWater
from breachflow.fluid.forces import AIR, WATER, FluidForces
from breachflow.fluid.kernels import cap_volume, submerged_fraction
from breachflow.field.sampling import uniform_snapshot
from breachflow.field.snapshot import grid_snapshot

G = 9.80665


def one(z, d=0.1, vel=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0), x=0.0, y=0.0, density=2650.0):
    return ParticleState.spheres([[x, y, z]], d / 2, Material(density=density), vel=[vel], omega=[omega])


def evaluate(model, state):
    f = np.zeros((state.n, 3))
    t = np.zeros((state.n, 3))
    model.accumulate(state, state.pos, state.vel, state.omega, 0.0, f, t)
    return f, t


@pytest.mark.parametrize("s_over_a", [0.0, 0.3, 1.0, 1.5, 2.0])
def test_cap_volume_is_the_integral_of_the_slices(s_over_a):
    a = 0.7
    s = s_over_a * a
    ref, _ = quad(lambda z: math.pi * (a * a - z * z), -a, -a + s)  # discs from the bottom up
    assert cap_volume(s, a) == pytest.approx(ref, rel=1e-12, abs=1e-15)


def test_submerged_fraction_limits_and_symmetry():
    a = 0.25
    assert submerged_fraction(1.0, a, 0.0) == 0.0
    assert submerged_fraction(-1.0, a, 0.0) == 1.0
    assert submerged_fraction(0.0, a, 0.0) == pytest.approx(0.5, abs=1e-15)
    for dz in (0.05, 0.1, 0.2):
        assert submerged_fraction(dz, a, 0.0) + submerged_fraction(-dz, a, 0.0) == pytest.approx(1.0, abs=1e-14)


def test_buoyancy_of_a_resting_sphere_above_across_and_below_the_surface():
    d = 0.1
    vol = math.pi * d**3 / 6
    model = FluidForces(UniformWater(surface=0.0), velocity_profile="uniform")
    for z, phi in ((1.0, 0.0), (0.0, 0.5), (-1.0, 1.0)):
        f, _ = evaluate(model, one(z, d))
        want = (phi * WATER.rho + (1 - phi) * AIR.rho) * vol * G
        assert f[0] == pytest.approx([0.0, 0.0, want], rel=1e-12, abs=1e-15)
    # a straddling sphere: cap of height s = 0.03 m under water
    f, _ = evaluate(FluidForces(UniformWater(surface=0.0), air=None, velocity_profile="uniform"), one(0.02, d))
    assert f[0, 2] == pytest.approx(WATER.rho * math.pi * 0.03**2 * (3 * 0.05 - 0.03) / 3 * G, rel=1e-12)


def test_drag_force_value_direction_and_reynolds_number():
    d, speed = 0.02, 0.7
    model = FluidForces(UniformWater(surface=10.0, u=0.3), drag_law="clift_gauvin", air=None, velocity_profile="uniform")
    st = one(0.0, d, vel=(0.3, 0.0, -speed))  # moves with the current horizontally, sinks at 0.7 m/s
    f, _ = evaluate(model, st)
    re = speed * d / WATER.nu
    cd = 24 / re * (1 + 0.15 * re**0.687) + 0.42 / (1 + 42500 * re**-1.16)
    drag = 0.5 * cd * WATER.rho * math.pi * d**2 / 4 * speed**2
    buoy = WATER.rho * math.pi * d**3 / 6 * G
    assert f[0] == pytest.approx([0.0, 0.0, buoy + drag], rel=1e-12)


def test_crossing_rule_is_continuous_and_independent_of_direction():
    d = 0.08
    model = FluidForces(UniformWater(surface=0.0), velocity_profile="uniform")
    zs = np.linspace(-0.06, 0.06, 241)
    down = np.array([evaluate(model, one(z, d, vel=(0, 0, -2.0)))[0][0, 2] for z in zs])
    up = np.array([evaluate(model, one(z, d, vel=(0, 0, 2.0)))[0][0, 2] for z in zs])
    buoy = np.array([evaluate(model, one(z, d))[0][0, 2] for z in zs])
    # drag magnitude the same at the same depth whichever way the sphere crosses
    np.testing.assert_allclose(down - buoy, -(up - buoy), rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(np.diff(down))) < 0.02 * np.max(np.abs(down))  # no step anywhere
    assert (down - buoy)[0] == pytest.approx(
        0.5 * 0.0 + 0.5 * WATER.rho * math.pi * d**2 / 4 * 4.0 * FluidForces(0.0, velocity_profile="uniform").drag_law.cd(2.0 * d / WATER.nu),
        rel=1e-12)


def test_added_mass_follows_the_submerged_volume():
    d = 0.1
    vol = math.pi * d**3 / 6
    model = FluidForces(UniformWater(surface=0.0), xi=0.5, velocity_profile="uniform")
    st = ParticleState.spheres([[0, 0, -1.0], [5, 0, 0.0], [9, 0, 1.0]], d / 2)
    m = model.added_mass(st)
    np.testing.assert_allclose(m, 0.5 * vol * np.array([WATER.rho, 0.5 * (WATER.rho + AIR.rho), AIR.rho]), rtol=1e-12)
    assert FluidForces(0.0, xi=0.0, velocity_profile="uniform").added_mass(st) is None
    # rows only (what a static_models DEM asks for its awake particles): the same analytic values
    np.testing.assert_allclose(model.added_mass(st, idx=np.array([2, 0])),
                               0.5 * vol * np.array([AIR.rho, WATER.rho]), rtol=1e-12)


def shear_snapshot(gamma, extent=5.0, spacing=0.5, depth=4.0):
    x = np.arange(-extent, extent + spacing / 2, spacing)
    y = x.copy()
    u = gamma * np.broadcast_to(y[:, None], (y.size, x.size))
    return grid_snapshot(x, y, 0.0, np.full(u.shape, depth), u, np.zeros_like(u))


def test_convective_apparent_mass_term_in_a_shear_flow():
    # u = gamma y: a particle moving across the stream with v_y feels xi rho V_sub (v . grad) u = xi rho V gamma v_y e_x
    gamma, vy, d = 0.4, 1.5, 0.2
    snap = shear_snapshot(gamma)
    st = one(2.0, d, vel=(gamma * 0.3, vy, 0.0), y=0.3)  # moving with the local stream in x: no x drag
    for horizon in (None, 1e-5, 1e-2):
        model = FluidForces(snap, air=None, xi=0.5, torque=False, time_step=horizon, drag_law="constant", velocity_profile="uniform")
        f, _ = evaluate(model, st)
        vol = math.pi * d**3 / 6
        assert f[0, 0] == pytest.approx(0.5 * WATER.rho * vol * gamma * vy, rel=1e-9)
    # still water: no convective term at all
    f, _ = evaluate(FluidForces(uniform_snapshot(4.0), air=None, drag_law="constant", torque=False, velocity_profile="uniform"), st)
    assert f[0, 0] == pytest.approx(-0.5 * 0.44 * WATER.rho * math.pi * d**2 / 4 * math.hypot(gamma * 0.3, vy)
                                    * gamma * 0.3, rel=1e-9)


def test_torque_opposes_spin_and_follows_the_fluid_vorticity():
    d = 1.0
    # spin about z in still water is resisted (uniform field: virtual lattice)
    _, t = evaluate(FluidForces(UniformWater(surface=10.0), velocity_profile="uniform"), one(0.0, d, omega=(0, 0, 2.0)))
    assert t[0, 2] < 0 and abs(t[0, 0]) < 1e-12 and abs(t[0, 1]) < 1e-12
    # a sphere at rest in u = gamma y turns with the fluid's vorticity dv/dx - du/dy = -gamma
    snap = shear_snapshot(0.5, spacing=0.1)
    _, t = evaluate(FluidForces(snap, air=None, sampling="neighbourhood", velocity_profile="uniform"), one(2.0, d, vel=(0, 0, 0)))
    assert t[0, 2] < 0
    # ... and a uniform stream exerts none, wherever the gridpoints fall relative to the centre
    x = np.arange(-5, 5.01, 0.3)
    snap_u = grid_snapshot(x, x, 0.0, np.full((x.size, x.size), 4.0), np.full((x.size, x.size), 1.2),
                           np.zeros((x.size, x.size)))
    model = FluidForces(snap_u, air=None, velocity_profile="uniform")
    assert model.field.uniform
    model.field.uniform = False  # force the gridpoint path
    for x0, y0 in ((0.0, 0.0), (0.07, 0.11), (0.13, -0.04)):
        _, t = evaluate(model, one(2.0, d, x=x0, y=y0))
        assert np.abs(t[0]).max() < 1e-12


def test_particles_leaving_the_field_are_handled_explicitly():
    snap = uniform_snapshot(2.0, extent=(-1, 1, -1, 1), spacing=0.5)
    st = one(1.0, 0.1, x=5.0)
    with pytest.raises(PhysicsError, match="particle 0 at x=5.000"):
        evaluate(FluidForces(snap, velocity_profile="uniform"), st)
    f, _ = evaluate(FluidForces(snap, outside="air", velocity_profile="uniform"), st)
    assert f[0, 2] == pytest.approx(AIR.rho * math.pi * 0.1**3 / 6 * G, rel=1e-12)


def test_dry_cells_are_air():
    snap = uniform_snapshot(0.0, extent=(-2, 2, -2, 2), spacing=0.5)  # dry everywhere
    f, _ = evaluate(FluidForces(snap, velocity_profile="uniform"), one(0.04, 0.1, vel=(0, 0, -1.0)))
    cd = FluidForces(snap, velocity_profile="uniform").drag_law.cd(0.1 / AIR.nu)
    drag = 0.5 * cd * AIR.rho * math.pi * 0.01 / 4
    assert f[0, 2] == pytest.approx(AIR.rho * math.pi * 0.1**3 / 6 * G + drag, rel=1e-12)


def test_sleeping_particles_are_evaluated_at_rest_where_they_lie():
    model = FluidForces(UniformWater(surface=0.0), velocity_profile="uniform")
    st = ParticleState.spheres([[0, 0, -1.0], [3, 0, -1.0]], 0.05, vel=[[0, 0, -1.0], [0, 0, -1.0]])
    st.awake[1] = False
    garbage = st.pos.copy()
    garbage[1] = [1e9, 1e9, 1e9]  # an integrator's predicted row for a particle it does not move
    f = np.zeros((2, 3))
    model.accumulate(st, garbage, st.vel, st.omega, 0.0, f, np.zeros((2, 3)))
    assert f[1, 2] == pytest.approx(WATER.rho * math.pi * 0.1**3 / 6 * G, rel=1e-12)
    assert f[0, 2] > f[1, 2]


def test_part_of_the_sphere_below_the_bed_is_not_in_water():
    # sphere of radius 0.05 pressed 0.01 m into the bed under 1 m of water: V_sub = V - cap(0.01)
    snap = uniform_snapshot(1.0, bed=0.0, extent=(-2, 2, -2, 2), spacing=0.5)
    f, _ = evaluate(FluidForces(snap, air=None, velocity_profile="uniform"), one(0.04, 0.1))
    v_sub = math.pi * 0.1**3 / 6 - math.pi * 0.01**2 * (3 * 0.05 - 0.01) / 3
    assert f[0, 2] == pytest.approx(WATER.rho * v_sub * G, rel=1e-12)
