"""Fluid forces on a field seen from a turned grid (the nested solver's regional fallback,
``hydro.nested.FramedSampler``) are those of the turned flow, not of the unturned grid arrays."""
import math

import numpy as np
import pytest

from breachflow.dem.state import Material, ParticleState
from breachflow.fluid.forces import FluidForces
from breachflow.hydro.nested import FramedSampler
from breachflow.field.sampling import FieldSampler, uniform_snapshot
from breachflow.site.frame import GridFrame


@pytest.mark.parametrize("angle", [23.0, 137.0, -61.0])
@pytest.mark.parametrize("profile", ["log", "uniform"])
def test_drag_from_a_turned_field_follows_the_turned_velocity(angle, profile):
    u_map, v_map = 1.2, -0.4
    snap = uniform_snapshot(3.0, u=u_map, v=v_map, bed=0.0, extent=(-60.0, 60.0, -60.0, 60.0), spacing=2.0)
    frame = GridFrame(angle, (3.0, -2.0))
    framed = FramedSampler(snap, "bilinear", frame)
    # the same flow expressed in the grid's axes, on an unturned sampler: the reference
    th = math.radians(angle)
    u_grid = math.cos(th) * u_map + math.sin(th) * v_map
    v_grid = -math.sin(th) * u_map + math.cos(th) * v_map
    ref_snap = uniform_snapshot(3.0, u=u_grid, v=v_grid, bed=0.0, extent=(-60.0, 60.0, -60.0, 60.0), spacing=2.0)
    # the frame's own convention for turning a map vector into grid components
    ug, vg = frame.vector_to_grid(np.array([u_map]), np.array([v_map]))
    assert (float(ug[0]), float(vg[0])) == pytest.approx((u_grid, v_grid), abs=1e-12)
    pos = np.array([[1.3, -0.7, 1.0], [-4.1, 2.2, 0.6]])
    forces = []
    for field in (FieldSampler(ref_snap, method="bilinear"), framed):
        st = ParticleState.spheres(pos, np.full(2, 0.4), Material(density=2650.0))
        model = FluidForces(field, velocity_profile=profile, outside="air")
        f = np.zeros((2, 3))
        t = np.zeros((2, 3))
        model.accumulate(st, st.pos, st.vel, st.omega, 0.0, f, t, idx=np.arange(2))
        forces.append(f)
    np.testing.assert_allclose(forces[1], forces[0], rtol=1e-9, atol=1e-9)
    # the horizontal drag points along the turned velocity (grid components), not along (u_map, v_map)
    fx, fy = forces[1][0, :2]
    assert math.atan2(fy, fx) == pytest.approx(math.atan2(v_grid, u_grid), abs=1e-6)


@pytest.mark.parametrize("angle", [23.0, -61.0])
def test_fused_and_step_paths_agree_on_a_turned_nonuniform_field(angle):
    """A flowing, non-uniform regional field (the fused kernels would apply to its grid arrays): the
    forces equal the step-by-step path's, which samples through ``FramedSampler.sample``."""
    snap = uniform_snapshot(3.0, u=1.2, v=-0.4, bed=0.0, extent=(-60.0, 60.0, -60.0, 60.0), spacing=2.0)
    X, Y = np.meshgrid(snap.x.values, snap.y.values)
    snap["u"] = (("y", "x"), 1.2 + 0.02 * X - 0.01 * Y)
    snap["v"] = (("y", "x"), -0.4 + 0.015 * Y)
    framed = FramedSampler(snap, "bilinear", GridFrame(angle, (3.0, -2.0)))
    rng = np.random.default_rng(7)
    pos = np.column_stack([rng.uniform(-20, 20, 12), rng.uniform(-20, 20, 12), rng.uniform(0.3, 2.8, 12)])
    out = []
    for compiled in (True, False):
        st = ParticleState.spheres(pos, np.full(12, 0.4), Material(density=2650.0))
        model = FluidForces(framed, velocity_profile="log", outside="air", compiled=compiled)
        f = np.zeros((12, 3))
        t = np.zeros((12, 3))
        model.accumulate(st, st.pos, st.vel, st.omega, 0.0, f, t, idx=np.arange(12))
        out.append(f)
    np.testing.assert_allclose(out[0], out[1], rtol=1e-9, atol=1e-9)
