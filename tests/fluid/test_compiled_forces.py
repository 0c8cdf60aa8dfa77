"""The fused fluid-force kernels (breachflow.fluid.compiled) give the step-by-step FluidForces' forces.

Random particle states on a non-uniform grid field with dry cells: fully and partially submerged,
above the water, on dry ground, outside the field, asleep (evaluated at rest where they lie), both
sampling methods, with and without air, torque and a fixed convective horizon.
"""
import numpy as np
import pytest

from breachflow.dem.state import Material, ParticleState
from breachflow.errors import PhysicsError
from breachflow.fluid.forces import FluidForces
from breachflow.hydro.snapshot import grid_snapshot


def breach_like_field(spacing=0.7):
    """Water 0-3 m deep over a sloping bed, a jet-like velocity field and a dry bank (x > 6 m)."""
    x = np.arange(-10.0, 10.0 + 1e-9, spacing)
    y = np.arange(-8.0, 8.0 + 1e-9, spacing * 1.3)
    X, Y = np.meshgrid(x, y)
    bed = 0.05 * X + 0.1 * np.sin(Y)
    surface = 2.5 + 0.02 * Y
    depth = np.where(X > 6.0, 0.0, np.maximum(surface - bed, 0.0))
    u = np.where(depth > 0, 3.0 * np.exp(-(Y / 4.0) ** 2) + 0.2 * X / 10, 0.0)
    v = np.where(depth > 0, 0.5 * np.sin(X / 3.0), 0.0)
    return grid_snapshot(x, y, bed, depth, u, v)


def random_state(rng, n=60):
    x = rng.uniform(-12.0, 12.0, n)  # some outside the field (|x| > 10.35 m)
    y = rng.uniform(-9.0, 9.0, n)
    d = rng.uniform(0.2, 2.5, n)
    z = rng.uniform(-0.5, 4.5, n)  # below, across and above the surface (about 2.5 m)
    pos = np.column_stack([x, y, z])
    st = ParticleState.spheres(pos, d / 2, Material(density=2650.0), vel=rng.normal(0, 2.0, (n, 3)),
                               omega=rng.normal(0, 1.0, (n, 3)))
    st.awake[rng.random(n) < 0.25] = False
    return st


def forces(model, st, pos, idx=None):
    f = np.zeros((st.n, 3))
    t = np.zeros((st.n, 3))
    model.accumulate(st, pos, st.vel, st.omega, 0.0, f, t, idx=idx)
    return f, t


@pytest.mark.parametrize("sampling", ["bilinear", "neighbourhood"])
@pytest.mark.parametrize("kw", [{}, {"air": None}, {"torque": False, "time_step": 1e-3},
                                {"drag_law": "morrison", "xi": 0.0}, {"wind": (3.0, -1.0, 0.0)}])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fused_forces_match_the_step_by_step_path(sampling, kw, seed):
    rng = np.random.default_rng(seed)
    snap = breach_like_field()
    st = random_state(rng)
    fused = FluidForces(snap, sampling=sampling, outside="air", **kw)
    ref = FluidForces(snap, sampling=sampling, outside="air", compiled=False, **kw)
    assert fused._fused is not None and ref._fused is None
    # an integrator's predicted positions: garbage in the rows of sleepers (they are taken at rest)
    pred = st.pos + 0.01 * rng.normal(size=st.pos.shape)
    pred[~st.awake] = 1e9
    for idx in (None, np.flatnonzero(st.awake), np.sort(rng.choice(st.n, 17, replace=False))):
        f1, t1 = forces(fused, st, pred, idx)
        f0, t0 = forces(ref, st, pred, idx)
        scale = np.abs(f0).max()
        np.testing.assert_allclose(f1, f0, rtol=1e-12, atol=1e-12 * scale)
        np.testing.assert_allclose(t1, t0, rtol=1e-12, atol=1e-12 * max(np.abs(t0).max(), 1e-30))
        if fused.xi > 0:
            rows = np.arange(st.n) if idx is None else idx
            np.testing.assert_allclose(fused.added_mass(st, idx=rows), ref.added_mass(st, idx=rows), rtol=1e-13)
            np.testing.assert_allclose(fused.added_mass(st), ref.added_mass(st), rtol=1e-13)
    # the cases the comparison must cover actually occur in the sample
    phi = ref.submerged_fraction(st.pos, st.radius)
    assert (phi == 0).any() and (phi == 1).any() and ((phi > 0) & (phi < 1)).any()
    assert (np.abs(st.pos[:, 0]) > 10.35).any() and (~st.awake).any()


def test_fused_path_refuses_particles_outside_the_field_like_the_reference():
    snap = breach_like_field()
    st = ParticleState.spheres([[0.0, 0.0, 1.0], [30.0, 1.0, 1.0]], 0.5)
    for compiled in (True, False):
        model = FluidForces(snap, compiled=compiled)
        with pytest.raises(PhysicsError, match="particle 1 at x=30.000 m"):
            forces(model, st, st.pos)
        with pytest.raises(PhysicsError, match="particle 1 at x=30.000 m"):
            model.added_mass(st)
