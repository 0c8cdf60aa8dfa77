"""The DEM driver's neighbour list and sleeping are components (``sim.pairs``, ``sim.sleepers``), checked
against expectations computed here independently of the driver: the pair list equals a brute-force
all-pairs search at every build, no touching pair is ever missing from it, and sleeping changes neither
where spheres come to rest nor which pairs are listed."""
import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane
from breachflow.dem.pairlist import PairList
from breachflow.dem.sleeping import Sleepers

ROCK = Material(density=2650, kn=1e6, friction=0.5, c_cn=2e3)
PILE = Material(density=2650, kn=1e6, friction=0.5, rolling_friction=0.3, c_cn=2e3)
G = 9.80665


def test_the_driver_is_composed_not_inherited():
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)])
    assert DemSimulation.__mro__ == (DemSimulation, object)
    assert isinstance(sim.pairs, PairList) and sim.pairs.sim is sim
    assert isinstance(sim.sleepers, Sleepers) and sim.sleepers.sim is sim
    sim.add_particles([[0.0, 0.0, 1.0], [3.0, 0.0, 1.0]], radius=0.5, material=ROCK)
    assert sim.pairs.pos_build.shape == (2, 3) and sim.sleepers.count.shape == (2,)


def brute_pairs(pos, radius, reach, rows):
    """All pairs (i < j) with at least one of *rows* whose centres are closer than r_i + r_j + reach."""
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    near = d < radius[:, None] + radius[None, :] + reach
    mine = np.zeros(len(pos), bool)
    mine[rows] = True
    i, j = np.nonzero(np.triu(near & (mine[:, None] | mine[None, :]), k=1))
    return set(zip(i.tolist(), j.tolist()))


def pile(seed, sleeping, compiled=False, layers=3):
    """Spheres of mixed sizes (uniform enough for one cell per particle) rained into a box of four walls."""
    h = 1.1
    walls = [Plane((0, 0, 0), (0, 0, 1), ROCK), Plane((-h, 0, 0), (1, 0, 0), ROCK), Plane((h, 0, 0), (-1, 0, 0), ROCK),
             Plane((0, -h, 0), (0, 1, 0), ROCK), Plane((0, h, 0), (0, -1, 0), ROCK)]
    sim = DemSimulation(boundaries=walls, sleeping=sleeping, sleep_velocity=1e-2, sleep_check=5)
    sim.compiled = compiled
    rng = np.random.default_rng(seed)
    layer = np.stack(np.meshgrid(np.arange(4) * 0.5 - 0.75, np.arange(4) * 0.5 - 0.75), -1).reshape(-1, 2)
    n = 16 * layers
    xy = np.tile(layer, (layers, 1)) + rng.uniform(-0.02, 0.02, (n, 2))  # 16 per layer, jittered
    pos = np.column_stack([xy, 0.3 + np.arange(n) // 16 * 0.5 + rng.uniform(0, 0.02, n)])
    sim.add_particles(pos, rng.uniform(0.2, 0.24, n), PILE, vel=rng.normal(0, 0.3, (n, 3)))
    return sim


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("sleeping", [False, True])
def test_pair_list_equals_a_brute_force_search_at_every_build(seed, sleeping):
    """After every rebuild the list is exactly the pairs with an awake partner whose centres were closer than
    ``r_i + r_j + skin`` (awake spheres at their build positions, sleepers where they sleep); at every step
    each touching pair with an awake partner is listed."""
    sim = pile(seed, sleeping)
    pl, s = sim.pairs, sim.state
    built = []
    for name in ("rebuild", "rebuild_list"):
        real = getattr(pl, name)
        setattr(pl, name, lambda real=real: built.append(1) or real())
    checked = 0
    for step in range(1500):
        built.clear()
        awake_before = s.awake.copy()
        sim.step(1)
        rows = np.flatnonzero(s.awake & s.active)
        listed = set(zip(pl.pa.tolist(), pl.pb.tolist()))
        if built and not (s.awake & ~awake_before).any():  # a rebuild, no wake since (that adds pairs)
            checked += 1
            at_build = np.where(s.awake[:, None], pl.pos_build, s.pos)
            assert listed == brute_pairs(at_build, s.radius, sim.skin, rows)
        touching = brute_pairs(s.pos, s.radius, 0.0, rows)
        assert touching <= listed, sorted(touching - listed)[:5]
    assert checked >= 10
    if sleeping:
        assert (~s.awake).sum() >= 10  # many fell asleep, and the lists with sleepers were checked too


@pytest.mark.parametrize("seed", [3, 4])
def test_sleeping_gives_the_resting_state_of_a_run_without_it(seed):
    """Spheres dropped apart onto a floor come to rest at ``z = r - m g / kn`` (the static overlap of the
    linear spring), with sleeping on and off alike; with it on they end asleep and cost fewer particle-steps."""
    runs = {}
    for sleeping in (False, True):
        sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)], sleeping=sleeping, sleep_velocity=1e-3)
        rng = np.random.default_rng(seed)
        xy = np.stack(np.meshgrid(np.arange(5) * 1.5, np.arange(4) * 1.5), -1).reshape(-1, 2)
        r = rng.uniform(0.3, 0.5, len(xy))
        pos = np.column_stack([xy, r + rng.uniform(0.2, 1.5, len(xy))])
        sim.add_particles(pos, r, ROCK)
        res = sim.run_to_equilibrium(1e-7, max_steps=200_000)
        assert res.converged
        runs[sleeping] = sim
        z_rest = r - sim.state.mass * G / ROCK.kn
        np.testing.assert_allclose(sim.state.pos[:, 2], z_rest, rtol=0, atol=2e-4 * r.min())
        np.testing.assert_allclose(sim.state.pos[:, :2], xy, rtol=0, atol=1e-9)
    off, on = runs[False], runs[True]
    np.testing.assert_allclose(on.state.pos, off.state.pos, rtol=0, atol=2e-4 * 0.3)
    assert not on.state.awake.any() and off.state.awake.all()
    assert on.particle_steps < off.particle_steps
