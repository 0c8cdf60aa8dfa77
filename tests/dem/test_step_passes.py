"""The fused per-particle passes of the compiled DEM loop (dem/steploop.py ``first_pass`` / ``second_pass``,
issue 16) and the periodic wrap that skips its division inside the range (dem/neighbours.py ``wrapped``):
bit for bit what the separate passes and the plain formula ``x - L floor((x - lo) / L)`` give."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane
from breachflow.dem.neighbours import wrap_and_check

ROCK = Material(density=2650, kn=1e6, ks=1e6, friction=0.5, c_cn=2e3, c_cs=1e3, c_cf=1e3)


def plain_wrap(x, lo, L):
    return x - L * math.floor((x - lo) / L)


@pytest.mark.parametrize("lo,L", [(0.0, 1.0), (-3.0, 6.0), (0.1, 0.3), (-7.25, 11.2), (1e3, 3.0)])
def test_wrap_equals_the_plain_formula_bit_for_bit(lo, L):
    """At and next to both ends of the range (the largest doubles below ``lo + L``, ``lo`` itself, -0.0),
    inside, and periods away on either side."""
    rng = np.random.default_rng(7)
    xs = [lo, lo + L, -0.0, 0.0, np.nextafter(lo, -np.inf), np.nextafter(lo, np.inf),
          np.nextafter(lo + L, -np.inf), np.nextafter(lo + L, np.inf), lo + L - 1e-15, lo + 1e-300]
    xs += list(lo + L * rng.uniform(-3, 4, 400)) + list(lo + L * rng.uniform(0, 1, 400))
    xs += [lo + k * L + s for k in range(-3, 4) for s in (-1e-12, 0.0, 1e-12)]
    pos = np.zeros((len(xs), 3))
    pos[:, 0] = xs
    pos[:, 1] = xs[::-1]
    pos[:, 2] = 1.0
    want = pos.copy()
    want[:, 0] = [plain_wrap(x, lo, L) for x in pos[:, 0]]
    want[:, 1] = [plain_wrap(x, lo, L) for x in pos[:, 1]]
    n = len(xs)
    geom = np.array([lo, lo, 0.0, 1.0, 1.0, 1.0, L, L])
    active = np.ones(n, bool)
    nleft, bad = wrap_and_check(np.arange(n), pos, np.zeros((n, 3)), np.zeros((n, 3)), geom, np.array([1, 1]),
                                np.zeros(6), False, active, active.copy(), np.zeros(n, np.int64))
    assert (nleft, bad) == (0, -1)
    np.testing.assert_array_equal(pos, want, strict=True)
    assert np.array_equal(np.signbit(pos), np.signbit(want))


def test_wrap_retires_leavers_and_reports_the_first_non_finite():
    pos = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, -2.0], [np.nan, 0.5, 0.5], [0.5, 2.5, 9.0], [np.inf, 0, 0]])
    vel = np.ones((5, 3))
    om = np.ones((5, 3))
    active = np.ones(5, bool)
    awake = active.copy()
    ids = np.zeros(5, np.int64)
    geom = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 2.0])
    box = np.array([0.0, 1.0, 0.0, 1.0, -1.0, 1.0])  # y periodic: only x and z can be left
    nleft, bad = wrap_and_check(np.arange(5), pos, vel, om, geom, np.array([0, 1]), box, True, active, awake, ids)
    assert bad == 2 and nleft == 2 and list(ids[:2]) == [1, 3]
    assert list(active) == [True, False, True, False, True] and list(awake) == list(active)
    assert pos[3, 1] == 0.5 and (vel[[1, 3]] == 0).all() and (om[[1, 3]] == 0).all() and (vel[0] == 1).all()


def pour(integrator, compiled, seed):
    """Spheres falling onto a floor, periodic in x and y, a few thrown upwards out of the domain."""
    rng = np.random.default_rng(seed)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)], dt=5e-4, sleeping=False,
                        integrator=integrator, periodic_x=(-2.5, 2.5), periodic_y=(-1.5, 3.0),
                        domain=(-9, 9, -9, 9, -1, 6))
    sim.compiled = compiled
    n = 60
    pos = np.column_stack([rng.uniform(-2.5, 2.5, n), rng.uniform(-1.5, 3.0, n), 0.3 + 0.45 * np.arange(n) / 6])
    vel = rng.normal(0, 2.0, (n, 3))
    vel[:2, 2] = 30.0
    sim.add_particles(pos, 0.2, ROCK, vel=vel)
    sim.state.c_gn[:] = 0.3 * sim.state.mass
    sim.state.c_gw[:] = 0.3 * sim.state.inertia
    return sim


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("seed", [1, 2])
def test_fused_passes_equal_the_python_step_periodic_in_x_and_y(integrator, seed):
    """The compiled loop (fused passes, the rebuild check taken from the first pass) against stepping in
    Python (the separate kernels of the integrators), with particles crossing both periodic seams and
    leaving the domain; state, histories and rebuild positions identical bit for bit."""
    ref, new = pour(integrator, False, seed), pour(integrator, True, seed)
    crossed = np.zeros(ref.state.n, bool)
    for n in (1, 5, 400, 1200):
        x0 = new.state.pos[:, :2].copy()
        assert ref.step(n) == new.step(n)
        crossed |= (np.abs(new.state.pos[:, :2] - x0) > 1.0).any(axis=1)
        sa, sb = ref.save_state(), new.save_state()
        for k in sa:
            np.testing.assert_array_equal(sa[k], sb[k], err_msg=k, strict=True)
        np.testing.assert_array_equal(ref.pairs.pos_build, new.pairs.pos_build, strict=True)
        assert ref.left_domain == new.left_domain
    assert crossed.sum() >= 5 and len(new.left_domain) >= 2
