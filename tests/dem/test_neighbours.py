"""Neighbour search against brute force, history rotation, O(N) behaviour of the pair search."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, ParticleState
from breachflow.dem import neighbours
from breachflow.dem import pair_contacts as contacts
from breachflow.dem.pairlist import PairList


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
    sim.pairs.rebuild()
    return set(zip(sim.pairs.pa.tolist(), sim.pairs.pb.tolist()))


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
    sim.pairs.sleep_grid_dirty = True
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
    assert sim.pairs.pa.size == len(got)  # no duplicates
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
    perpendicular to the normal, turning with the pair. (Lever arm D/2 as in docs/theory.md, *DEM contact*, so the pair
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
        # the driver's kernel with the driver's argument types (a wrapper would compile a copy of it)
        contacts.pair_forces_interval(np.array([0]), np.array([1]), hist, np.zeros((1, 3)), np.zeros(1, bool), pos,
                                      vel, w, vel, w, False, np.full(2, r), np.ones(2), np.ones(2), props,
                                      np.ones(2, bool), np.ones(2, bool), geom, periodic, dt, 1e9, f, t,
                                      np.zeros(2, bool), np.zeros(2, np.int64), np.zeros(1, np.int64), 0.0, 0.0, 0)
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
    sim.pairs.rebuild()
    sim.pairs.hist[:] = [0.0, 2e-4, 0.0]
    sim.fix_particles([0, 1])  # both asleep now: history must be parked
    sim.pairs.rebuild()
    assert sim.pairs.hist.shape[0] == 0 and sim.pairs.frozen_keys.size == 1
    sim._fixed[:] = False
    sim.wake_all()
    sim.pairs.rebuild()
    assert sim.pairs.hist.shape[0] == 1
    np.testing.assert_allclose(sim.pairs.hist[0], [0.0, 2e-4, 0.0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sort_and_carry_equals_a_global_sort_and_key_lookup(seed):
    """The CSR rebuild (counting sort by a, short rows by b, one merge walk for the histories) gives the
    order of ``np.sort`` of the keys ``a << 32 | b`` and each pair's old history (zero when new), against a
    dictionary lookup."""
    rng = np.random.default_rng(seed)
    npart = 300
    def random_pairs(m):
        a = rng.integers(0, npart - 1, m)
        b = a + 1 + (rng.integers(0, 40, m) % (npart - 1 - a))
        return np.unique((a << 32) | b)
    old_keys = random_pairs(900)
    new_keys = np.union1d(rng.choice(old_keys, old_keys.size // 2, replace=False), random_pairs(400))
    cand = rng.permutation(new_keys)  # the search's order is arbitrary
    old_h = rng.normal(size=(old_keys.size, 3))
    old_r = rng.normal(size=(old_keys.size, 3))
    n = cand.size
    out = [np.empty(n + 5, np.int64), np.empty(n + 5, np.int64), np.empty((n + 5, 3)), np.empty((n + 5, 3))]
    neighbours.sort_and_carry(n, cand >> 32, cand & 0xFFFFFFFF, old_keys >> 32, old_keys & 0xFFFFFFFF, old_h, old_r,
                              npart, *out)
    np.testing.assert_array_equal((out[0][:n] << 32) | out[1][:n], np.sort(cand))
    old = {int(k): (h, r) for k, h, r in zip(old_keys, old_h, old_r)}
    for k, key in enumerate(np.sort(cand)):
        h, r = old.get(int(key), (np.zeros(3), np.zeros(3)))
        np.testing.assert_array_equal(out[2][k], h)
        np.testing.assert_array_equal(out[3][k], r)
    assert 0 < np.isin(new_keys, old_keys).sum() < n  # carried and new pairs both present


#: an empty sleeping grid (start, entry particle, entry code, table bits), as ``PairList.grid`` gives it
NO_SLEEPERS = (np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), 0)


def test_relist_grows_its_buffers_and_alternates_them():
    """From empty buffers the capacity grows to hold the list, later rebuilds reuse it (no new arrays), the
    new list never lives in the buffer the old one is read from, and histories carry over."""
    rng = np.random.default_rng(4)
    n, L, skin = 400, 8.0, 0.1
    pos = rng.uniform(0, L, (n, 3))
    radius = np.full(n, 0.5)
    geom = np.array([0, 0, 0, 1.1, 1.1, 1.1, 1.0, 1.0])
    per, ncell, idx = np.zeros(2, np.int64), np.ones(2, np.int64), np.arange(n)
    pb_ = np.zeros((n, 3))
    bufs = neighbours.empty_buffers()
    lst = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)))
    ids = []
    for it in range(6):
        # the driver's rebuild of awake particles alone (PairList.relist): one cell each, empty sleeping grid
        *new, touch, bufs = neighbours.rebuild(idx, pos, radius, 0.5 * skin, geom, per, ncell, True, NO_SLEEPERS,
                                               *lst, pb_, bufs)
        keys = (new[0] << 32) | new[1]
        assert set(zip(new[0].tolist(), new[1].tolist())) == brute_pairs(pos, radius, skin)
        assert np.all(np.diff(keys) > 0) and not touch.any()
        np.testing.assert_array_equal(pb_, pos)
        for a in new:
            assert not any(np.may_share_memory(a, b) for b in lst)
        old = {int(k): h for k, h in zip((lst[0] << 32) | lst[1], lst[2])}
        for k, h in zip(keys, new[2]):
            np.testing.assert_array_equal(h, old.get(int(k), np.zeros(3)))
        new[2][:] = rng.normal(size=new[2].shape)  # histories to carry over
        lst = tuple(new)
        ids.append(tuple(id(b) for b in bufs))
        pos = pos + rng.normal(0, 0.03, pos.shape)
    assert bufs[0].shape[0] >= lst[0].size and bufs[2].shape[0] >= lst[0].size
    assert ids[2] == ids[4] and ids[3] == ids[5]  # capacity reused: the two sets alternate


def sheared_pair(skin, tracer_speed, compiled, periodic):
    """Two spheres meeting obliquely with spin (a long sticking / sliding contact that winds up the
    tangential spring) in zero gravity, and a far tracer whose speed sets when the skin check fires."""
    mat = Material(kn=1e6, ks=1e6, friction=0.4, c_cn=1e3, c_cs=5e2, rolling_friction=0.05)
    kw = dict(periodic_x=(-150.0, 150.0)) if periodic else {}
    x0 = 149.55 if periodic else 0.0  # the contact straddles the periodic seam
    sim = DemSimulation(gravity=(0, 0, 0), sleeping=False, integrator="velocity_verlet", dt=2e-4, skin=skin, **kw)
    sim.compiled = compiled
    sim.add_particles([[x0, 0.0, 0.0], [x0 + 0.9, 0.3, -0.05], [x0 - 40.0, 20.0, 0.0]], 0.5, mat,
                      vel=[[0.0, 0.0, 0.0], [-0.15, -1.0, 0.4], [tracer_speed, 0.0, 0.0]],
                      omega=[[0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    return sim


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("tracer_speed", [13.0, 17.0, 23.5, 31.0])
def test_sheared_contact_keeps_its_spring_across_rebuilds(tracer_speed, periodic, monkeypatch):
    """A contact whose list is rebuilt while it is loaded keeps its tangential and rolling springs
    exactly: the same run with a skin so large that the list is never rebuilt gives bit-identical
    springs and motion at every step. The tracer speed shifts the rebuilds to other phases of the
    contact; both the step-by-step path and the compiled many-steps loop (which rebuilds inside the
    compiled call) are checked."""
    calls = []
    real = PairList.rebuild
    monkeypatch.setattr(PairList, "rebuild", lambda self: calls.append(id(self.sim)) or real(self))
    ref = sheared_pair(60.0, tracer_speed, False, periodic)
    sims = [sheared_pair(None, tracer_speed, False, periodic), sheared_pair(None, tracer_speed, True, periodic)]
    rebuilds_loaded = 0
    spring = 0.0
    for step in range(400):
        build = sims[0].pairs.pos_build.copy()
        ref.step(1)
        sims[0].step(1)
        touching = ref.pairs.pa.size and np.any(ref.pairs.hist != 0.0)
        k = np.flatnonzero((ref.pairs.pa == 0) & (ref.pairs.pb == 1))
        kk = np.flatnonzero((sims[0].pairs.pa == 0) & (sims[0].pairs.pb == 1))
        if touching and not np.array_equal(build, sims[0].pairs.pos_build):
            rebuilds_loaded += 1
        if k.size:
            spring = max(spring, float(np.linalg.norm(ref.pairs.hist[k])))
            np.testing.assert_array_equal(sims[0].pairs.hist[kk], ref.pairs.hist[k])
            np.testing.assert_array_equal(sims[0].pairs.rhist[kk], ref.pairs.rhist[k])
        np.testing.assert_array_equal(sims[0].state.pos, ref.state.pos)
        np.testing.assert_array_equal(sims[0].state.omega, ref.state.omega)
    assert rebuilds_loaded >= 3  # rebuilds happened while the spring was wound up
    assert spring > 1e-4  # m: a wound-up tangential spring (overlaps are ~1e-3 m)
    assert calls.count(id(ref)) == 1 and calls.count(id(sims[0])) >= 15  # ref: built once, never rebuilt
    sims[1].step(400)  # one compiled call: its rebuilds run inside it
    assert calls.count(id(sims[1])) == 1
    for name in ("pos", "vel", "omega"):
        np.testing.assert_array_equal(getattr(sims[1].state, name), getattr(ref.state, name), err_msg=name)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("sizes", ["uniform", "ratio 4"])
def test_rebuild_between_events_lists_awake_and_sleeping_partners(seed, periodic, sizes):
    """The rebuild the compiled loops run while particles sleep (:func:`.neighbours.rebuild` with the
    sleeping grid): every pair within the skin except those of two sleepers, against brute force; each
    pair once although particles woken after the sleeping grid was built still sit in it (at their old
    place: they are then moved); sorted keys; histories carried over from the old list, zero for new pairs
    (against a dictionary lookup); build positions recorded for the awake particles only."""
    rng = np.random.default_rng(seed)
    n, L, skin = 600, 7.0, 0.08
    radius = rng.uniform(0.2, 0.25, n) if sizes == "uniform" else np.where(rng.random(n) < 0.2, 0.5, 0.125)
    pos = rng.uniform(0, L, (n, 3))
    kw = dict(periodic_x=(0.0, L), periodic_y=(0.0, L)) if periodic else {}
    sim = DemSimulation(ParticleState.spheres(pos, radius), gravity=(0, 0, 0), skin=skin, **kw)
    assert sim.single_bin == (sizes == "uniform")
    asleep = rng.random(n) < 0.6
    sim.state.awake[:] = ~asleep
    sim._refresh_idx()
    sim.pairs.sleep_grid_dirty = sim.pairs.dirty = True
    sim.pairs.rebuild()  # at the event: the sleeping grid is built, the list is the awake particles' and theirs
    woken = rng.choice(np.flatnonzero(asleep), 40, replace=False)
    sim.sleepers.wake(woken)  # still in the (now stale) sleeping grid
    asleep[woken] = False
    assert not sim.pairs.sleep_grid_dirty and sim.pairs.relist_inline()
    sim.pairs.hist = rng.normal(size=sim.pairs.hist.shape)  # histories to carry over
    sim.pairs.rhist = rng.normal(size=sim.pairs.rhist.shape)
    old = {(int(a), int(b)): (h, r) for a, b, h, r in zip(sim.pairs.pa, sim.pairs.pb, sim.pairs.hist, sim.pairs.rhist)}
    s = sim.state
    s.pos[~asleep] += rng.normal(0, 0.05, (int((~asleep).sum()), 3))  # awake ones (and the woken) move
    if periodic:
        s.pos[:, :2] %= L
    build = sim.pairs.pos_build.copy()
    cand = np.empty(20 * n, np.int64), np.empty(20 * n, np.int64)
    n_found = neighbours._search(sim.idx, s.pos, s.radius, 0.5 * skin, sim.geom, sim.periodic, sim.ncell,
                                 sim.single_bin, sim.pairs.sgrid, *cand)
    sim.pairs.rebuild()
    periods = (L, L) if periodic else (None, None)
    want = sorted((i, j) for i, j in brute_pairs(s.pos, s.radius, skin, periods) if not (asleep[i] and asleep[j]))
    got = list(zip(sim.pairs.pa.tolist(), sim.pairs.pb.tolist()))
    assert got == want  # same pairs, each once, in key order
    assert n_found > len(want)  # the search met pairs of woken particles twice
    assert len(want) > 100 and any(a in woken or b in woken for a, b in want)
    for k, key in enumerate(got):
        h, r = old.get(key, (np.zeros(3), np.zeros(3)))
        np.testing.assert_array_equal(sim.pairs.hist[k], h)
        np.testing.assert_array_equal(sim.pairs.rhist[k], r)
    assert 0 < sum(key in old for key in got) < len(got)  # carried and new pairs both present
    np.testing.assert_array_equal(sim.pairs.pos_build[~asleep], s.pos[~asleep])
    np.testing.assert_array_equal(sim.pairs.pos_build[asleep], build[asleep])
    assert not sim.pairs.touch.any()


def _scene(case, seed, periodic):
    """Unfavourable layouts for the dense bins (:func:`.neighbours.bin_dense`): (positions, radii, skin,
    period or None). Periods hold 6 cells of L / 6 >= 1.1 m (radius <= 0.5, skin 0.1); at this L the float just
    below L divided by the cell size rounds up to 6, one cell past the period's last."""
    rng = np.random.default_rng(seed)
    skin = 0.1
    L = 7.294288239180386
    h = L / 6
    assert math.floor(np.nextafter(L, 0.0) / h) == 6
    if case == "on cell faces":  # every coordinate a cell face k h (the period's ends 0 and L included) or 1e-13 off
        n = 500
        k = rng.integers(0, 7, (n, 3)).astype(float)
        jitter = rng.choice([0.0, 0.0, 0.0, 1e-13, -1e-13, 0.5 * h, 0.25 * h], (n, 3))
        pos = k * h + jitter
        radius = rng.uniform(0.3, 0.5, n)
    elif case == "across the seams":  # near x = 0 / L, y = 0 / L and the corner; some just outside the period
        n = 400
        pos = rng.uniform(0, L, (n, 3))
        near = rng.random((n, 2)) < 0.7
        pos[:, :2] = np.where(near, rng.choice([0.0, L], (n, 2)) + rng.uniform(-0.6, 0.6, (n, 2)), pos[:, :2])
        below = np.nextafter(L, 0.0)
        pos[:6, :2] = [[0.0, 0.0], [L, L], [-1e-14, L - 1e-14], [L, 0.0], [below, 1.0], [2.0, below]]
        pos[:, 2] = rng.uniform(0, 3 * h, n)
        radius = rng.uniform(0.3, 0.5, n)
        if not periodic:
            pos[:, :2] += L  # the same cloud, away from the origin, no period
    elif case == "alone in a cell":  # sparse: one particle per occupied cell, a few close pairs
        n = 60
        pos = rng.uniform(0, L, (n, 3)) * [1, 1, 2]
        pos[n // 2:] = pos[: n // 2] + rng.normal(0, 0.6, (n // 2, 3))
        radius = rng.uniform(0.3, 0.5, n)
    else:  # "crowded, mixed sizes": ~15 particles of radius 0.3-0.5 per cell
        n = 900
        pos = rng.uniform(0, L, (n, 3)) * [1, 1, 0.25]
        radius = rng.uniform(0.3, 0.5, n)
    pos[-1, :2] = np.nextafter(L, 0.0)  # inside the period, its cell rounds to one past the last
    return pos, radius, skin, (L if periodic else None)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("case", ["on cell faces", "across the seams", "alone in a cell", "crowded, mixed sizes"])
def test_dense_bins_pairs_equal_brute_force_at_unfavourable_layouts(case, periodic, seed):
    """The dense-bin half stencil (padded bins, ghost copies across periodic seams, 5 contiguous runs per
    cell) lists every pair within the skin exactly once, in key order, against brute force: particles on
    cell faces (and on the period's ends), pairs across the x, y and corner seams (some positions just
    outside the period, wrapped for binning), particles alone in their cells, crowded cells of mixed size."""
    pos, radius, skin, L = _scene(case, seed, periodic)
    kw = dict(periodic_x=(0.0, L), periodic_y=(0.0, L)) if periodic else {}
    sim = DemSimulation(ParticleState.spheres(pos, radius), gravity=(0, 0, 0), skin=skin, sleeping=False, **kw)
    assert sim.single_bin and (not periodic or (sim.ncell[0] == 6 and sim.geom[3] == L / 6))
    if periodic:  # a particle inside the period whose cell rounds to one past the period's last
        p = sim.state.pos[:, :2]
        assert ((p < L) & (np.floor(p / sim.geom[3]) == 6)).any()
    dim = neighbours.bin_dense(sim.idx, sim.state.pos, sim.state.radius, 0.5 * skin, sim.geom, sim.periodic,
                               sim.ncell)[0]
    assert dim[0] > 0  # the dense path, not the hashed fallback
    sim.pairs.rebuild()
    got = list(zip(sim.pairs.pa.tolist(), sim.pairs.pb.tolist()))
    want = sorted(brute_pairs(pos, radius, skin, (L, L) if periodic else (None, None)))
    assert got == want
    assert len(want) >= 10
    if case == "across the seams" and periodic:  # pairs that exist only through the x, y and corner seams
        d = pos[sim.pairs.pb] - pos[sim.pairs.pa]
        assert (np.abs(d[:, 0]) > L / 2).any() and (np.abs(d[:, 1]) > L / 2).any()
        assert ((np.abs(d[:, 0]) > L / 2) & (np.abs(d[:, 1]) > L / 2)).any()


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("spare", [-3, -1, 0, 1])
def test_dense_search_fills_buffers_of_any_capacity_with_the_right_pairs(spare, periodic, seed):
    """The dense search writes every candidate after the last kept pair (branch-free) and only counts the
    pairs beyond its buffers' capacity. With buffers of exactly the pair count (spare 0), a candidate met
    after the last pair could overwrite it: the stored pairs must still be brute force's (the callers take a
    count equal to the capacity as complete); one slot more, or too few (counted, caller retries)."""
    pos, radius, skin, L = _scene("crowded, mixed sizes", seed, periodic)
    kw = dict(periodic_x=(0.0, L), periodic_y=(0.0, L)) if periodic else {}
    sim = DemSimulation(ParticleState.spheres(pos, radius), gravity=(0, 0, 0), skin=skin, sleeping=False, **kw)
    want = sorted(brute_pairs(pos, radius, skin, (L, L) if periodic else (None, None)))
    cap = len(want) + spare
    a, b = np.empty(cap, np.int64), np.empty(cap, np.int64)
    n = neighbours._find_pairs_dense(sim.idx, sim.state.pos, sim.state.radius, 0.5 * skin, sim.geom, sim.periodic,
                                     sim.ncell, a, b)
    assert n == len(want)
    if n <= cap:
        assert sorted(zip(a[:n].tolist(), b[:n].tolist())) == want
