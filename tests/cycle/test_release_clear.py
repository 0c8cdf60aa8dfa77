"""A mass is never released inside a mass already in the breach: where the pile stands higher than the
release height (an emergent dam, a crest above the water), the new mass is lowered onto it instead.
Spawned inside a placed mass, the contact law pushes it out with the overlap's elastic energy and can shoot
it out of the breach: a loss no flow caused."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from breachflow.cycle.placement import PlacementPlan, clear_of
from breachflow.dem import DemSimulation
from breachflow.dem.state import Material


def surface(x, y):
    return np.full_like(np.asarray(x, float), 3.0)


def _pile(rng, n, top):
    """*n* placed masses around the release line, their centres up to *top* (m)."""
    pos = np.column_stack([rng.uniform(-6, 6, n), rng.uniform(-1.5, 1.5, n), rng.uniform(0.0, top, n)])
    return pos, rng.uniform(0.8, 1.2, n)


def _gaps(new, r_new, pos, r):
    """Surface gap of every (new, placed) pair and every new pair (m); negative where they overlap."""
    d = np.linalg.norm(new[:, None, :] - pos[None, :, :], axis=2) - (r_new[:, None] + r[None, :])
    i, j = np.triu_indices(len(new), 1)
    dn = np.linalg.norm(new[i] - new[j], axis=1) - (r_new[i] + r_new[j])
    return d, dn


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("top", [2.0, 4.5, 8.0])
def test_no_new_mass_starts_inside_a_placed_one(seed, top):
    """Random piles whose crest is below, at and well above the release height (water 3 m + 1 m + r):
    after the release no new mass overlaps a placed one or another new one, and a lifted mass rests on
    something (its gap to the nearest mass is at most the 1 mm vertical clearance), so it was lifted no higher than needed."""
    rng = np.random.default_rng(seed)
    plan = PlacementPlan(diameter=(1.8, 2.2), batch=6, positions="line", start=(-5.5, 0.0), stop=(5.5, 0.0))
    placed = _pile(rng, 40, top)
    free = plan.release(3, seed, surface)
    rel = plan.release(3, seed, surface, placed=placed)
    np.testing.assert_array_equal(rel.pos[:, :2], free.pos[:, :2])
    d, dn = _gaps(rel.pos, rel.radius, *placed)
    assert d.min() >= -1e-9 and (dn.size == 0 or dn.min() >= -1e-9)
    lifted = rel.pos[:, 2] > free.pos[:, 2] + 1e-12
    for i in np.flatnonzero(lifted):
        mates = [k for k in range(len(rel.pos)) if k != i
                 and np.hypot(*(rel.pos[i, :2] - rel.pos[k, :2])) < rel.radius[i] + rel.radius[k]]
        if not mates:  # lifted over the pile alone (a batch mate above it is stacked by ``destack``'s own rule)
            assert 0.0 <= d[i].min() <= 1e-3 + 1e-9  # by the overlap's vertical extent + 1 mm, no more
    if top >= 4.5:
        assert lifted.any()  # the sweep does reach piles above the release height


def test_release_above_a_low_pile_is_unchanged():
    """A pile that stays below the release height changes nothing: the release is bit-identical."""
    rng = np.random.default_rng(4)
    plan = PlacementPlan(diameter=(1.8, 2.2), batch=5, positions="line", start=(-5.5, 0.0), stop=(5.5, 0.0))
    pos, r = _pile(rng, 30, 1.0)  # centres <= 1 m, tops <= 2.2 m; releases at >= 4.9 m
    a, b = plan.release(2, 7, surface), plan.release(2, 7, surface, placed=(pos, r))
    np.testing.assert_array_equal(a.pos, b.pos)


def test_clear_of_puts_a_mass_on_top_at_the_contact_distance():
    """One placed sphere straight below at the same height: the new one sits on it, centres 2 r + 1 mm apart;
    offset by d horizontally it sits at sqrt((r_i + r_j)^2 - d^2) + 1 mm above it (hand arithmetic)."""
    for d in (0.0, 0.6, 1.5):
        out = clear_of(np.array([[d, 0.0, 5.0]]), np.array([1.0]), np.array([[0.0, 0.0, 5.2]]), np.array([0.9]))
        assert out[0, 2] == pytest.approx(5.2 + np.sqrt(1.9 ** 2 - d ** 2) + 1e-3, abs=1e-12)
    out = clear_of(np.array([[2.0, 0.0, 5.0]]), np.array([1.0]), np.array([[0.0, 0.0, 5.2]]), np.array([0.9]))
    assert out[0, 2] == 5.0  # 2.0 m apart horizontally: no overlap possible


def test_a_mass_spawned_inside_another_is_shot_out():
    """Why it matters: two 2 m spheres of rock spawned with a 0.6 m overlap, contact stiffness 2e7 N/m as in
    the default closure, no gravity: the pair flies apart at metres per second (the overlap's elastic energy
    k delta^2 / 2 = 3.6 MJ over 2 x 11 t gives sqrt(3.6e6 / 11.1e3) = 18 m/s each, less the damping)."""
    mass = 2650.0 * 4.0 / 3.0 * np.pi
    mat = Material(density=2650.0, kn=2e7, friction=0.6).with_restitution(0.3, mass / 2)
    sim = DemSimulation(gravity=(0, 0, 0), sleeping=False)
    sim.add_particles([[0.0, 0.0, 0.0], [1.4, 0.0, 0.0]], 1.0, mat)
    sim.run(0.5)
    speed = np.linalg.norm(sim.state.vel[:2], axis=1)
    assert speed.min() > 3.0
