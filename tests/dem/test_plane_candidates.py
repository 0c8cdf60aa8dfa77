"""Candidate lists of the fixed planes in the compiled loop (issue 16, ``steploop_fluid.list_planes``,
``walls.plane_candidates`` / ``candidates_hold``): the plane loops run over the particles near each plane
only, with results bit-identical to the Python step (which loops over all awake particles) at unfavourable
cases: spheres exactly at the margin at a build, spheres approaching a plane fast right after a build (the
step-averaged law's reach, drifts larger than the margin's reserve), spheres bouncing in and out of the
lists between builds, leaving the domain, falling asleep and woken, several planes (floor, walls in x and
y, a tilted one), a plane across a periodic axis, and plane histories left by a restored state."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, steploop
from breachflow.dem.wall_contacts import CANDIDATE_RESERVE, candidates_hold, plane_candidates

from .test_steploop import assert_same

ROCK = Material(density=2650, kn=1e6, ks=1e6, friction=0.5, c_cn=2e3, c_cs=1e3, c_cf=1e3, rolling_friction=0.1)
R = 0.25
SKIN = 0.125  # the lists' margin: gap below the skin at the build (binary-exact, so gaps equal it exactly)
GAPS = (0.0, 0.3, 0.5, 0.875, 1.0, 1.5)  # gap at the start, in skins (1.0: exactly at the margin)
SPEEDS = (0.5, 5.0, 30.0, 60.0)  # m/s towards the plane


def planes():
    return [Plane((0, 0, 0), (0, 0, 1), ROCK), Plane((-2.0, 0, 0), (1, 0, 0), ROCK),
            Plane((2.0, 0, 0), (-1, 0, 0), ROCK), Plane((0, -2.0, 0), (0, 1, 0), ROCK),
            Plane((-1.9, 0, 0), (1, 0, 0.3), ROCK)]


def scene(integrator, law, *, sleeping=False, compiled=True, seed=0):
    """Floor, walls at x = -2, x = 2, y = -2 and a tilted plane (none at y = +2: the domain ends at 2.5 there,
    spheres thrown that way leave it). Spheres resting on the floor; spheres whose gap to the floor or to the
    x = 2 wall is GAPS skins, approaching it at SPEEDS; a column dropped from above (bouncing in and out of
    the lists); three thrown out of the domain."""
    sim = DemSimulation(boundaries=planes(), dt=5e-4, sleeping=sleeping, integrator=integrator, contact_law=law,
                        domain=(-2.5, 2.5, -2.5, 2.5, -1.0, 30.0), skin=SKIN)
    sim.compiled = compiled
    rng = np.random.default_rng(seed)
    pos, vel = [], []
    xy = [(x, y) for x in np.arange(-1.5, 1.51, 0.6) for y in np.arange(-1.5, 1.51, 0.6)]  # 36 columns
    k = 0
    for g in GAPS:
        for v in SPEEDS:  # towards the floor
            x, y = xy[k]
            k += 1
            pos.append((x, y, R + g * SKIN))
            vel.append((rng.normal(0, 0.1), rng.normal(0, 0.1), -v))
    for x, y in xy[k:]:  # resting on the floor
        pos.append((x, y, R - 1e-3))
        vel.append((0.0, 0.0, 0.0))
    for j, g in enumerate(GAPS):  # towards the wall x = 2, high up
        for m, v in enumerate(SPEEDS[:3]):
            pos.append((2.0 - R - g * SKIN, -1.5 + 0.6 * m, 3.0 + 0.6 * j))
            vel.append((v, 0.0, 0.0))
    for j in range(12):  # a column dropped from above
        pos.append((rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), 8.0 + 0.6 * j))
        vel.append(rng.normal(0, 1.0, 3))
    for j in range(3):  # leave the domain through y = 2.5
        pos.append((-1.0 + j, 1.0, 6.0))
        vel.append((0.0, 40.0, 0.0))
    sim.add_particles(np.array(pos), R, ROCK, vel=np.array(vel))
    s = sim.state
    s.c_gn[:] = 1.0 * s.mass if sleeping else 0.0  # damped: comes to rest and sleeps
    s.c_gw[:] = 1.0 * s.inertia if sleeping else 0.0
    return sim


def assert_boundaries_same(a, b):
    for pa, pb in zip(a.boundaries, b.boundaries):
        for name in ("hist", "rhist", "reaction"):
            np.testing.assert_array_equal(getattr(pa, name), getattr(pb, name), err_msg=name, strict=True)
    assert a.n_contacts == b.n_contacts


def assert_far_rows_are_plus_zero(sim):
    """Every awake particle farther from a plane than any interval reach has both history rows +0.0 in every bit."""
    s = sim.state
    for b in sim.boundaries:
        gap = (s.pos - b.point) @ b.normal - s.radius
        far = s.awake & s.active & (gap > 0.5 * SKIN)
        assert far.any()
        for rows in (b.hist, b.rhist):
            assert not rows[far].any() and not np.signbit(rows[far]).any()


@pytest.mark.parametrize("law", ["step_averaged", "hooke_history"])
@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
def test_plane_lists_give_the_python_steps_bit_for_bit(integrator, law, monkeypatch):
    """Spheres at and around the margin approaching the floor and a wall at up to 60 m/s (drifts of 3 cm per
    step, beyond the margin's reserve: some steps run the full loop), others resting, bouncing, leaving:
    state, pair and plane histories, plane reactions and contact counts equal the Python step's."""
    calls = []
    real = steploop.run
    monkeypatch.setattr(steploop, "run", lambda *a, **k: calls.append(1) or real(*a, **k))
    ref = scene(integrator, law, compiled=False)
    new = scene(integrator, law)
    for n in (1, 2, 5, 40, 400, 1600):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
        assert_boundaries_same(ref, new)
    assert len(calls) >= 4 and len(new.left_domain) >= 3
    assert_far_rows_are_plus_zero(new)


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("speed", [2.0, 40.0, 120.0, 200.0, 400.0])
def test_a_sphere_just_outside_the_margin_hitting_the_floor_right_after_a_build(integrator, speed):
    """One sphere whose gap is the margin (and one a rounding above it) at a build, then thrown at the floor
    at up to 400 m/s (a drift of 20 cm, more than the margin, per step; the interval reaches 10 cm): its
    contact is not missed, bit for bit as the Python step."""
    sims = []
    for compiled in (False, True):
        sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)], dt=5e-4, sleeping=False,
                            integrator=integrator, domain=(-3, 3, -3, 3, -10, 10), skin=SKIN)
        sim.compiled = compiled
        sim.add_particles(np.array([(0.0, 0.0, R + SKIN), (1.0, 0.0, math.nextafter(R + SKIN, 1.0)),
                                    (-1.0, 0.0, R - 1e-3)]), R, ROCK)
        sim.step(1)  # the build (Python: the start forces); now thrown
        sim.state.vel[:2] = (0.0, 0.0, -speed)
        sims.append(sim)
    ref, new = sims
    for n in (1, 1, 1, 3, 30, 300):
        ref.step(n)
        new.step(n)
        assert_same(ref, new)
        assert_boundaries_same(ref, new)
    assert ref.state.vel[0, 2] > 0.0 or not ref.state.active[0]  # it hit the floor


@pytest.mark.parametrize("law", ["step_averaged", "hooke_history"])
def test_sleeping_and_waking_spheres_on_the_floor(law):
    """The damped scene settles and sleeps on the floor (run to equilibrium), then spheres thrown onto it
    wake sleepers: compiled calls between the events give the Python steps' results bit for bit."""
    ref = scene("predicted_verlet", law, sleeping=True, compiled=False, seed=4)
    new = scene("predicted_verlet", law, sleeping=True, seed=4)
    r_ref = ref.run_to_equilibrium(1e-5, max_steps=30000)
    r_new = new.run_to_equilibrium(1e-5, max_steps=30000)
    assert r_ref == r_new
    assert_same(ref, new)
    assert_boundaries_same(ref, new)
    assert (~new.state.awake & new.state.active).sum() > 20  # sleepers on the floor
    for sim in (ref, new):
        sim.add_particles(np.array([(0.0, 0.0, 2.0), (0.9, 0.3, 2.5)]), R, ROCK,
                          vel=np.array([(0.0, 0.0, -8.0), (0.0, 0.0, -6.0)]))
    asleep = int((~new.state.awake & new.state.active).sum())
    for n in (1, 10, 300, 1500):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
        assert_boundaries_same(ref, new)
    assert int((~new.state.awake & new.state.active).sum()) < asleep  # some were woken


@pytest.mark.parametrize("law", ["step_averaged", "hooke_history"])
def test_a_restored_history_of_a_far_sphere_is_cleared_as_by_the_full_loop(law):
    """Plane history rows left non-zero (or -0.0) on spheres far from the plane, as a restored state may hold
    them: the lists keep those spheres until the loop has cleared the rows to +0.0, as the Python step does."""
    sims = []
    for compiled in (False, True):
        sim = scene("velocity_verlet", law, compiled=compiled)
        sim.step(1)
        far = np.flatnonzero(sim.state.pos[:, 2] > 5.0)[:4]
        floor = sim.boundaries[0]
        floor.hist[far[0]] = (1e-4, 0.0, 0.0)
        floor.hist[far[1]] = (0.0, -0.0, 0.0)
        floor.rhist[far[2]] = (0.0, 0.0, -3.0)
        floor.rhist[far[3]] = (-0.0, 0.0, 0.0)
        sims.append(sim)
    ref, new = sims
    for n in (1, 50):
        ref.step(n)
        new.step(n)
        assert_same(ref, new)
        assert_boundaries_same(ref, new)
    assert_far_rows_are_plus_zero(new)


def test_a_plane_across_a_periodic_axis_has_no_list():
    """Periodic in x with a plane tilted in x: a sphere wrapped across the seam jumps along the plane's
    normal (here from 2.4 m above the plane into contact); the plane's loop runs over all particles."""
    sims = []
    for compiled in (False, True):
        sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK), Plane((0, 0, 0), (0.5, 0, 1), ROCK)],
                            dt=5e-4, sleeping=False, integrator="velocity_verlet", periodic_x=(-3.0, 3.0),
                            domain=(-3, 3, -3, 3, -5, 10), skin=SKIN)
        sim.compiled = compiled
        sim.add_particles(np.array([(2.5, 0.0, 1.75), (0.0, 1.0, R - 1e-3)]), R, ROCK,
                          vel=np.array([(20.0, 0.0, 0.0), (0.0, 0.0, 0.0)]))
        sims.append(sim)
    ref, new = sims
    for n in (1, 4, 20, 200):
        ref.step(n)
        new.step(n)
        assert_same(ref, new)
        assert_boundaries_same(ref, new)


def _one_plane_arrays(z, hist_row=(0.0, 0.0, 0.0), rhist_row=(0.0, 0.0, 0.0)):
    pos = np.array([[0.0, 0.0, zz] for zz in z])
    hist = np.zeros((len(z), 3))
    rhist = np.zeros((len(z), 3))
    hist[-1] = hist_row
    rhist[-1] = rhist_row
    return pos, np.full(len(z), R), hist, rhist


def test_candidates_at_the_margin_and_by_history_bits():
    """Gap exactly at the margin: left out; one rounding below it, or not a number: listed; a far sphere with
    any history bit set (-0.0 included) in either row: listed; order kept."""
    z = [R + SKIN, math.nextafter(R + SKIN, 0.0), R, R + 10.0, float("nan"), R + 5.0]
    for row, listed in (((0.0, 0.0, 0.0), False), ((0.0, -0.0, 0.0), True), ((1e-300, 0.0, 0.0), True)):
        for which in ("hist", "rhist"):
            pos, radius, hist, rhist = _one_plane_arrays(z, **{which + "_row": row})
            out = np.empty(len(z), np.int64)
            n = plane_candidates(np.arange(len(z), dtype=np.int64), pos, radius, np.zeros(3),
                                 np.array([0.0, 0.0, 1.0]), SKIN, hist, rhist, out)
            assert list(out[:n]) == [1, 2, 4] + ([5] if listed else []), (row, which)
            out = np.empty(len(z), np.int64)
            n = plane_candidates(np.array([5, 2, 1], np.int64), pos, radius, np.zeros(3), np.array([0.0, 0.0, 1.0]),
                                 SKIN, hist, rhist, out)
            assert list(out[:n]) == ([5] if listed else []) + [2, 1]


def test_the_guard_keeps_its_reserve():
    """The lists hold while displacement plus interval reach stay within (1 - reserve) of the margin."""
    m = SKIN
    assert candidates_hold(0.5 * m, 0.0, m) and candidates_hold(0.5 * m, (0.5 - CANDIDATE_RESERVE) * m, m)
    assert not candidates_hold(0.5 * m, math.nextafter((0.5 - CANDIDATE_RESERVE) * m, 1.0) + 1e-15, m)
    assert not candidates_hold(m, 0.0, m) and not candidates_hold(0.0, m, m)
    assert not candidates_hold(float("nan"), 0.0, m)
