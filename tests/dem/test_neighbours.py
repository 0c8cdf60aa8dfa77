"""Neighbour search against brute force, history rotation, O(N) behaviour of the pair search."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, ParticleState
from breachflow.dem import contacts


def brute_pairs(pos, radius, reach_extra, periods=(None, None)):
    n = len(pos)
    out = set()
    for i in range(n):
        d = pos - pos[i]
        for ax, L in enumerate(periods):
            if L is not None:
                d[:, ax] -= L * np.floor(d[:, ax] / L + 0.5)
        dist = np.linalg.norm(d, axis=1)
        for j in np.flatnonzero(dist < radius + radius[i] + reach_extra):
            if j > i:
                out.add((i, int(j)))
    return out


def sim_pairs(sim):
    sim._rebuild()
    return set(zip(sim._pa.tolist(), sim._pb.tolist()))


@pytest.mark.parametrize("periodic", [False, True])
def test_grid_pairs_equal_brute_force_with_size_ratio_10(periodic):
    rng = np.random.default_rng(1)
    n = 1500
    L = 8.0
    radius = np.where(rng.random(n) < 0.1, 1.0, 0.1) * rng.uniform(0.9, 1.0, n)  # 10:1
    pos = rng.uniform(0, L, (n, 3))
    kw = dict(periodic_x=(0.0, L), periodic_y=(0.0, L)) if periodic else {}
    sim = DemSimulation(ParticleState.spheres(pos, radius), gravity=(0, 0, 0), skin=0.05, **kw)
    # some particles asleep: pairs between two sleepers must be absent, all others present
    asleep = rng.random(n) < 0.5
    sim.state.awake[:] = ~asleep
    sim._refresh_idx()
    sim._sleep_grid_dirty = True
    got = sim_pairs(sim)
    periods = (L, L) if periodic else (None, None)
    want = {(i, j) for i, j in brute_pairs(pos, radius, 0.05, periods) if not (asleep[i] and asleep[j])}
    assert got == want
    assert len(want) > 50


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("cells", [4, 7])
@pytest.mark.parametrize("z_top", [3.0, 3000.0])
def test_half_stencil_pairs_equal_brute_force(periodic, cells, z_top):
    """Nearly uniform sizes, all awake: one cell per particle and the half (14-cell) stencil, each pair
    listed once; periodic ranges down to the smallest allowed (4 cells per period); a compact cloud (dense
    cell array) and one spread over 3 km in z (hashed grid)."""
    rng = np.random.default_rng(7)
    radius_max, skin = 0.5, 0.1
    L = cells * (2 * radius_max + skin) + 1e-9
    n = int(3.0 * L * L * 4)
    radius = rng.uniform(0.8, 1.0, n) * radius_max
    pos = np.column_stack([rng.uniform(-0.3, L + 0.3, (n, 2)), rng.uniform(-1.0, 3.0, n)])
    pos[: n // 4, 2] = rng.uniform(-1.0, z_top, n // 4)
    kw = dict(periodic_x=(0.0, L), periodic_y=(0.0, L)) if periodic else {}
    sim = DemSimulation(ParticleState.spheres(pos, radius), gravity=(0, 0, 0), skin=skin, sleeping=False, **kw)
    assert sim.single_bin and (not periodic or sim.ncell[0] == cells)
    got = sim_pairs(sim)
    assert sim._pa.size == len(got)  # no duplicates
    want = brute_pairs(pos, radius, skin, (L, L) if periodic else (None, None))
    assert got == want
    assert len(want) > 100


def test_pair_search_work_follows_awake_particles():
    """With all but a few particles asleep, only pairs touching awake particles are listed."""
    rng = np.random.default_rng(2)
    n = 2000
    pos = rng.uniform(0, 30, (n, 3))
    sim = DemSimulation(ParticleState.spheres(pos, 0.5), gravity=(0, 0, 0))
    sim.state.awake[:] = False
    sim.state.awake[:5] = True
    sim._refresh_idx()
    got = sim_pairs(sim)
    assert all(i < 5 or j < 5 for i, j in got)
    want = {(i, j) for i, j in brute_pairs(pos, np.full(n, 0.5), sim.skin) if i < 5 or j < 5}
    assert got == want


def test_shear_history_follows_rigid_rotation_of_the_pair():
    """Rotate a stuck pair rigidly (no relative motion): the shear spring keeps its length and stays
    perpendicular to the normal, turning with the pair. (Lever arm D/2 as in SPEC §5, so the pair
    just touches: a deep overlap would add a relative velocity omega * u_N at the contact.)"""
    r = 0.5 + 5e-10
    n_steps = 900
    total = math.pi / 2
    dtheta = total / n_steps
    omega = 1.0
    dt = dtheta / omega
    pos = np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]])
    hist = np.array([[0.0, 1e-4, 0.0]])  # initial shear displacement along +y
    props = np.tile(np.array([[1e9, 0.0, 1e7, 1e7, 0.0, 0.0, 0.0, 0.0]]), (2, 1))
    geom = np.array([0, 0, 0, 1, 1, 1, 1, 1.0])
    periodic = np.zeros(2, np.int64)
    f = np.zeros((2, 3))
    t = np.zeros((2, 3))
    for k in range(n_steps):
        th = (k + 1) * dtheta
        c, s = math.cos(th), math.sin(th)
        pos = np.array([[-0.5 * c, -0.5 * s, 0.0], [0.5 * c, 0.5 * s, 0.0]])
        vel = np.array([[0.5 * s * omega, -0.5 * c * omega, 0.0], [-0.5 * s * omega, 0.5 * c * omega, 0.0]])
        w = np.array([[0, 0, omega], [0, 0, omega]], float)
        f[:] = 0
        contacts.pair_forces(np.array([0]), np.array([1]), hist, np.zeros(1, bool), pos, vel, w, np.full(2, r),
                             props, np.ones(2, bool), np.ones(2, bool), geom, periodic, dt, 1e9, f, t,
                             np.zeros(2, bool), np.zeros(2, np.int64), np.zeros(1, np.int64))
    n = pos[1] - pos[0]
    n /= np.linalg.norm(n)
    h = hist[0]
    assert np.linalg.norm(h) == pytest.approx(1e-4, rel=1e-4)
    assert abs(h @ n) < 1e-12
    # +y turned by 90 degrees about z is -x
    assert h[0] == pytest.approx(-1e-4, rel=1e-2)


def test_history_survives_neighbour_list_rebuilds_and_sleep():
    """A sheared contact keeps its shear force across a rebuild and a sleep/wake of both partners."""
    mat = Material(kn=1e7, friction=0.0, adhesion=1e9)
    sim = DemSimulation(gravity=(0, 0, 0), sleeping=True, integrator="velocity_verlet")
    sim.add_particles([[0, 0, 0], [0.99, 0, 0]], 0.5, mat)
    sim._rebuild()
    sim._hist[:] = [0.0, 2e-4, 0.0]
    sim.fix_particles([0, 1])  # both asleep now: history must be parked
    sim._rebuild()
    assert sim._hist.shape[0] == 0 and sim._frozen_keys.size == 1
    sim._fixed[:] = False
    sim.wake_all()
    sim._rebuild()
    assert sim._hist.shape[0] == 1
    np.testing.assert_allclose(sim._hist[0], [0.0, 2e-4, 0.0])
