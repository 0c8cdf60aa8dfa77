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
from breachflow.field.snapshot import grid_snapshot


def breach_like_field(spacing=0.7, level=2.5):
    """Water 0-3 m deep (surface ~*level*) over a sloping bed, a jet-like velocity field and a dry bank (x > 6 m)."""
    x = np.arange(-10.0, 10.0 + 1e-9, spacing)
    y = np.arange(-8.0, 8.0 + 1e-9, spacing * 1.3)
    X, Y = np.meshgrid(x, y)
    bed = 0.05 * X + 0.1 * np.sin(Y)
    surface = level + 0.02 * Y
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
    fused = FluidForces(snap, sampling=sampling, outside="air", velocity_profile="uniform", **kw)
    ref = FluidForces(snap, sampling=sampling, outside="air", compiled=False, velocity_profile="uniform", **kw)
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
        model = FluidForces(snap, compiled=compiled, velocity_profile="uniform")
        with pytest.raises(PhysicsError, match="particle 1 at x=30.000 m"):
            forces(model, st, st.pos)
        with pytest.raises(PhysicsError, match="particle 1 at x=30.000 m"):
            model.added_mass(st)


def profile_state(rng, snap, n=80):
    """Particles over the field at heights chosen relative to the local bed and surface: exactly at the bed,
    inside the log law's dead layer (z < k_s/30), in the water column, straddling and above the surface,
    on the dry bank and outside the field."""
    from breachflow.field.sampling import FieldSampler

    x = rng.uniform(-11.0, 11.0, n)
    y = rng.uniform(-8.5, 8.5, n)
    s = FieldSampler(snap, "bilinear").sample(x, y)
    bed = np.where(np.asarray(s.inside), np.asarray(s.bed, float), 0.0)
    depth = np.where(np.asarray(s.inside), np.asarray(s.depth, float), 0.0)
    kind = np.arange(n) % 5
    z = np.select([kind == 0, kind == 1, kind == 2, kind == 3],
                  [bed, bed + rng.uniform(0.0, 2e-3, n), bed + rng.uniform(0.0, 1.0, n) * depth,
                   bed + depth + rng.uniform(-0.3, 0.3, n)], bed + depth + rng.uniform(0.5, 2.0, n))
    d = rng.uniform(0.1, 1.5, n)
    st = ParticleState.spheres(np.column_stack([x, y, z]), d / 2, Material(density=2650.0),
                               vel=rng.normal(0, 1.0, (n, 3)), omega=rng.normal(0, 1.0, (n, 3)))
    st.awake[rng.random(n) < 0.2] = False
    return st, depth


@pytest.mark.parametrize("profile", ["uniform", "log", "power"])
@pytest.mark.parametrize("roughness", [1e-3, 0.066, 0.5, 4.0])
@pytest.mark.parametrize("level", [2.5, 0.6])
@pytest.mark.parametrize("sampling", ["bilinear", "neighbourhood"])
def test_fused_forces_with_a_velocity_profile_match_the_step_by_step_path(profile, roughness, level, sampling):
    """Every velocity profile runs in the fused kernel and gives the step path's forces to round-off, over
    depths 0-3 m (level 2.5 m) and 0-1.1 m (level 0.6 m, the log law falls back to uniform where
    h < e^2 k_s / 30) and roughness 1 mm-4 m, with particles at the bed, in the dead layer, in the column,
    across and above the surface, on dry cells and outside the field."""
    snap = breach_like_field(level=level)
    rng = np.random.default_rng(int(roughness * 1000) + int(level * 10))
    st, depth = profile_state(rng, snap)
    kw = dict(sampling=sampling, outside="air", velocity_profile=profile, roughness=roughness)
    fused = FluidForces(snap, **kw)
    ref = FluidForces(snap, compiled=False, **kw)
    assert fused._fused is not None and ref._fused is None
    for horizon in (None, 2e-3):
        fused.time_step = ref.time_step = horizon
        for idx in (None, np.sort(rng.choice(st.n, 23, replace=False))):
            f1, t1 = forces(fused, st, st.pos, idx)
            f0, t0 = forces(ref, st, st.pos, idx)
            np.testing.assert_allclose(f1, f0, rtol=1e-12, atol=1e-12 * np.abs(f0).max())
            np.testing.assert_allclose(t1, t0, rtol=1e-12, atol=1e-12 * max(np.abs(t0).max(), 1e-30))
    np.testing.assert_allclose(fused.added_mass(st), ref.added_mass(st), rtol=1e-13)
    # the edge cases occur: dry cells, outside the field, centres above the surface and at the bed
    assert (depth == 0).any() and (np.abs(st.pos[:, 0]) > 10.35).any() and (~st.awake).any()
    if profile != "uniform":
        # the profile matters: the drag differs from the uniform profile's (fused path)
        uni = FluidForces(snap, sampling=sampling, outside="air", roughness=roughness, velocity_profile="uniform")
        assert not np.allclose(forces(uni, st, st.pos)[0], forces(fused, st, st.pos)[0], rtol=1e-6)


def test_fused_profile_uses_the_one_profile_definition():
    """A still sphere in the fused path feels U * profile_factor(z - bed, h, k_s): its drag equals the
    uniform profile's drag in a field scaled by that factor (constant C_D: drag ∝ |u| u)."""
    from breachflow.fluid.profile import factors

    from breachflow.field.sampling import FieldSampler

    snap = breach_like_field()
    st = ParticleState.spheres([[-2.0, 0.5, 0.0]], 0.05, Material(density=2650.0))
    s = FieldSampler(snap, "bilinear").sample(np.array([-2.0]), np.array([0.5]))
    bed, h = float(s.bed[0]), float(s.depth[0])
    st.pos[0, 2] = bed + 0.3
    for profile in ("log", "power"):
        f = float(factors(profile, 0.3, h, 0.066))
        assert 0.3 < f < 1.0
        scaled = snap.copy()
        scaled["u"] = snap["u"] * f
        scaled["v"] = snap["v"] * f
        kw = dict(drag_law="constant", air=None, torque=False, xi=0.0, roughness=0.066)
        model = FluidForces(snap, velocity_profile=profile, **kw)
        assert model._fused is not None  # the fused kernel serves the profile
        a = forces(model, st, st.pos)[0]
        b = forces(FluidForces(scaled, velocity_profile="uniform", **kw), st, st.pos)[0]
        np.testing.assert_allclose(a, b, rtol=1e-12)
