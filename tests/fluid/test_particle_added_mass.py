"""Each mass's own apparent-mass coefficient xi (its material's; default the run's [fluid] xi).

A sphere released at rest in still water starts with the acceleration (rho_s - rho_w) g / (rho_s + xi rho_w)
(buoyancy and gravity over the mass plus the apparent mass, no drag at rest): two masses with their own xi in
one still-water field each take their own, against this formula."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material
from breachflow.dem.state import ParticleState
from breachflow.errors import InputError
from breachflow.field.snapshot import grid_snapshot
from breachflow.fluid.forces import FluidForces
from breachflow.materials import MaterialMix, get_material

G = 9.80665
RHO_W = 1000.0


def still_water(depth=20.0, slope=0.0):
    """Still water *depth* m deep over a flat bed, or over a bed of *slope* with one dry corner cell (no longer a
    uniform field: the fused kernels read it)."""
    x = np.arange(-20.0, 20.0 + 1e-9, 1.0)
    y = np.arange(-20.0, 20.0 + 1e-9, 1.0)
    X, _ = np.meshgrid(x, y)
    z = np.zeros_like(X)
    h = depth - slope * X
    if slope:
        h[0, 0] = 0.0
    return grid_snapshot(x, y, slope * X, h, z, z)


def _first_acceleration(xis, rho_s, run_xi=0.5, dt=1e-4, path="uniform"):
    ff = FluidForces(still_water(slope=0.0 if path == "uniform" else 0.05), xi=run_xi, air=None, torque=False,
                     outside="air")
    assert (ff._fused is None) == (path == "uniform")  # the step-by-step kernels, or the fused ones
    static = path == "grid_compiled"
    sim = DemSimulation(models=[ff], sleeping=False, dt=dt, static_models=static, integrator="velocity_verlet")
    pos = [[-10.0 + 6.0 * k, 0.0, 10.0] for k in range(len(xis))]
    for p, xi, rho in zip(pos, xis, rho_s):
        sim.add_particles([p], 0.5, Material(density=rho), added_mass_coefficient=xi)
    sim.step(1)
    from breachflow.dem import steploop

    # after the first step a static fused model is advanced by the compiled step loop, else in Python
    assert (steploop.runner(sim) is not None) == static
    sim.step(3)
    return -sim.state.vel[:, 2] / sim.t


@pytest.mark.parametrize("path", ["uniform", "grid", "grid_compiled"])  # Python step / fused kernels / step loop
@pytest.mark.parametrize("rho_s", [2650.0, 1990.0, 2400.0])
def test_each_mass_starts_with_its_own_xi(rho_s, path):
    xis = [float("nan"), 0.0, 1.0, 2.5]  # NaN: the run's xi (0.5)
    a = _first_acceleration(xis, [rho_s] * len(xis), path=path)
    for got, xi in zip(a, [0.5, 0.0, 1.0, 2.5]):
        want = (rho_s - RHO_W) * G / (rho_s + xi * RHO_W)
        assert got == pytest.approx(want, rel=1e-6), xi
    # a larger xi: a smaller acceleration (more water to carry along)
    assert a[1] > a[0] > a[2] > a[3]


def test_apparent_mass_of_each_particle_is_its_xi_times_the_displaced_water():
    ff = FluidForces(still_water(slope=0.05), xi=0.5, air=None, torque=False)
    st = ParticleState.spheres(np.array([[0.0, 0.0, 5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]]), np.array([0.4, 0.7, 1.0]),
                               Material(density=2650.0))
    st.added_mass_coefficient = np.array([np.nan, 1.2, 0.0])
    m = ff.added_mass(st)
    vol = 4.0 / 3.0 * math.pi * np.array([0.4, 0.7, 1.0]) ** 3
    np.testing.assert_allclose(m, np.array([0.5, 1.2, 0.0]) * RHO_W * vol, rtol=1e-12)
    # a run without an apparent mass still gives a mass its own
    ff0 = FluidForces(still_water(), xi=0.0, air=None, torque=False)  # the step-by-step kernel
    np.testing.assert_allclose(ff0.added_mass(st), np.array([0.0, 1.2, 0.0]) * RHO_W * vol, rtol=1e-12)
    st.added_mass_coefficient[:] = np.nan
    assert ff0.added_mass(st) is None


def test_a_material_states_its_xi_and_the_mix_passes_it_per_mass():
    rock = get_material("HMA_1000_3000", added_mass_coefficient=0.8)
    bag = get_material("big_bag", added_mass_coefficient=1.5)
    units = MaterialMix([rock, bag, "concrete_cube"]).unit_parameters()
    assert [u["added_mass_coefficient"] for u in units] == [0.8, 1.5, None]
    with pytest.raises(InputError, match="added_mass_coefficient"):
        MaterialMix([get_material("HMA_1000_3000", added_mass_coefficient=-0.1)])
    with pytest.raises(InputError, match="added_mass_coefficient"):
        ParticleState.empty().add([[0.0, 0.0, 0.0]], 0.5, added_mass_coefficient=-1.0)
