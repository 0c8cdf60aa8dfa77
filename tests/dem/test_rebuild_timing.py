"""The pair list's rebuild check runs after the drift, before the forces (dem/pairlist.py ``after_drift``,
dem/steploop_fluid.py ``fluid_verlet_steps``), as LAMMPS' Verlet (``neighbor->decide()`` after the drift):
at every force evaluation each awake particle is within ``skin/2`` of its build position, so two spheres
unlisted at the build (gap above the skin) cannot touch unlisted.

The unfavourable case: two spheres approach head-on at ``s = v dt`` per step each, their gap at the build
``skin + delta``. After step ``k`` each moved ``k s <= skin/2`` (no rebuild); step ``k + 1`` moves them to
``skin/2 + (1 - f) s`` with ``f`` the phase of the crossing (``skin/2 = (k + f) s``), where they overlap by
``2 (1 - f) s - delta > 0``. A check before the drift (the old order) evaluates that step's forces with the
old list: the overlapping pair gets no force.
"""
import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material
from breachflow.dem.neighbours import displacement_since

ROCK = Material(density=2650, kn=1e7, ks=1e7, friction=0.5, c_cn=4e4)
R = 0.5


def approach(integrator, k, f, c, direction, shift, compiled):
    """Two spheres of radius R, no gravity, no boundaries, default skin and dt, approaching along the unit
    *direction* so that each crosses ``skin/2`` from the build during step ``k + 1`` at phase *f*; gap at
    the build ``skin + c (1 - f) s``; the pair shifted by *shift*. Returns (sim, unit direction, s)."""
    probe = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator)
    probe.add_particles([[0.0, 0.0, 0.0]], R, ROCK)  # the default dt and skin
    skin, dt = probe.skin, probe.dt
    s = 0.5 * skin / (k + f)
    gap = skin + c * (1.0 - f) * s
    e = np.asarray(direction, float) / np.linalg.norm(direction)
    x0 = np.asarray(shift, float)
    sim = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator)
    sim.compiled = compiled
    sim.add_particles([x0, x0 + e * (2 * R + gap)], R, ROCK, vel=[e * (s / dt), -e * (s / dt)])
    assert sim.skin == skin == pytest.approx(0.1) and sim.dt == dt
    return sim, e, s


def check_evaluation(sim, e):
    """After a step (positions are those of its force evaluation; the closing kick moves none): every awake
    particle within skin/2 of its build position, and an overlapping pair pushed apart."""
    s = sim.state
    overlap = 2 * R - np.linalg.norm(s.pos[1] - s.pos[0])
    if overlap > 0.0:
        assert sim.force[0] @ e < 0.0 < sim.force[1] @ e, f"overlap {overlap:.3g} m without a contact force"
    moved = displacement_since(sim.idx, s.pos, sim._pos_build, sim.geom, sim.periodic)
    assert moved <= 0.5 * sim.skin, f"forces evaluated {moved:.6g} m from the build (skin/2 {0.5 * sim.skin})"
    return overlap


CASES = [(k, f, c, d, sh) for k in (3, 7, 19) for f in (0.1, 0.35, 0.6, 0.9) for c, d, sh in
         ((0.5, (1, 0, 0), (0.0, 0.0, 0.0)), (0.9, (1, 1, 1), (0.37, -1.21, 2.53)), (0.2, (0, 0.6, -0.8), (5.1, 0.0, 0.0)))]


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("k,f,c,direction,shift", CASES)
def test_approaching_spheres_get_their_contact_force_at_the_first_overlap(integrator, k, f, c, direction, shift):
    """Python path (``DemSimulation._one_step``), one step at a time: the first overlap happens at step k + 1
    (just after each sphere crossed skin/2 from the build) and gets its force; the state after each
    step equals the compiled loop's (one call of n - 1 steps after the first Python step, fresh for each n),
    whose last step is checked the same way."""
    py, e, s = approach(integrator, k, f, c, direction, shift, compiled=False)
    first = None
    for n in range(1, k + 5):
        py.step(1)
        if check_evaluation(py, e) > 0.0 and first is None:
            first = n
        if n in (k, k + 1, k + 2, k + 4):
            cp, e2, _ = approach(integrator, k, f, c, direction, shift, compiled=True)
            cp.step(n)
            assert cp.steps == n and py.steps == n
            check_evaluation(cp, e2)
            np.testing.assert_array_equal(cp.state.pos, py.state.pos)
            np.testing.assert_array_equal(cp.state.vel, py.state.vel)
            np.testing.assert_array_equal(cp.force, py.force)
            np.testing.assert_array_equal(cp._pos_build, py._pos_build)
    assert first == k + 1  # the case is the unfavourable one: first overlap right after crossing skin/2


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("k,f", [(3, 0.35), (7, 0.9), (19, 0.1)])
def test_the_compiled_loop_decides_after_the_drift_within_one_call(integrator, k, f, monkeypatch):
    """The compiled loop on its own: the whole approach and bounce in one call (after the first Python
    step), the calls counted; the step of the first overlap is the last of a call of k steps."""
    from breachflow.dem import steploop

    calls = []
    real = steploop.run
    monkeypatch.setattr(steploop, "run", lambda sim, n, *a: calls.append(n) or real(sim, n, *a))
    sim, e, s = approach(integrator, k, f, 0.5, (1, 0, 0), (0.0, 0.0, 0.0), compiled=True)
    sim.step(k + 1)
    assert calls == [k] and sim.steps == k + 1
    assert check_evaluation(sim, e) > 0.0


def drifting_lattice(integrator, compiled, speed):
    """27 spheres on a lattice of spacing 2R + 2 skin (never within the skin of each other), all moving at
    *speed* along (1, 2, 2)/3: nothing touches, the list is rebuilt only for the displacement."""
    sim = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator, sleeping=False)
    sim.compiled = compiled
    g = np.arange(3) * (2 * R + 0.2)
    pos = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    sim.add_particles(pos, R, ROCK, vel=np.tile(np.array([1.0, 2.0, 2.0]) / 3.0 * speed, (27, 1)))
    return sim


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("frac", [0.23, 0.5, 0.77])
def test_uniform_drift_rebuilds_once_per_half_skin(integrator, frac):
    """A uniform drift of ``s`` per step: the list is rebuilt at the end of every m-th step's drift, m the
    least with ``m s > skin/2``, and at no other step: the build positions change exactly at steps m, 2m, ...
    (Python path, each step) and, in the compiled loop (one call), are those of the last multiple of m."""
    probe = drifting_lattice(integrator, False, 1.0)
    skin, dt = probe.skin, probe.dt
    m = 6
    s = 0.5 * skin / (m - 1 + frac)  # (m - 1) s < skin/2 < m s
    assert (m - 1) * s < 0.5 * skin < m * s
    nsteps = 5 * m + 3
    py = drifting_lattice(integrator, False, s / dt)
    py.step(1)  # the first step builds at the start positions
    builds = []
    for n in range(2, nsteps + 1):
        before = py._pos_build.copy()
        py.step(1)
        if not np.array_equal(before, py._pos_build):
            builds.append(n)
        moved = displacement_since(py.idx, py.state.pos, py._pos_build, py.geom, py.periodic)
        assert moved <= 0.5 * skin, f"step {n}: forces evaluated {moved:.6g} m from the build"
    assert builds == list(range(m, nsteps + 1, m))
    cp = drifting_lattice(integrator, True, s / dt)
    cp.step(nsteps)
    last = nsteps - nsteps % m
    start = drifting_lattice(integrator, False, s / dt).state.pos
    v = np.array([1.0, 2.0, 2.0]) / 3.0 * s
    np.testing.assert_allclose(cp._pos_build, start + last * v, rtol=0, atol=1e-3 * s)
    np.testing.assert_array_equal(cp._pos_build, py._pos_build)
    np.testing.assert_array_equal(cp.state.pos, py.state.pos)


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
def test_a_resting_bed_is_not_rebuilt(integrator, monkeypatch):
    """Spheres resting on a floor (settled, sleeping off so all stay awake and integrated): the compiled
    loop and the Python path rebuild the list no more (neither the build positions nor the list change)."""
    from breachflow.dem import Plane

    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)], integrator=integrator, sleeping=False)
    g = np.arange(5) * (2 * R + 0.02)  # neighbours 0.02 m apart: listed, not touching
    xy = np.array(np.meshgrid(g, g, indexing="ij")).reshape(2, -1).T
    sim.add_particles(np.column_stack([xy, np.full(25, R + 1e-3)]), R, ROCK)
    sim.step(3000)
    v = np.linalg.norm(sim.state.vel, axis=1).max()
    assert v < 1e-4 and sim.n_contacts == 25 and sim._pa.size == 40  # at rest on the floor
    calls = []
    from breachflow.dem import neighbours

    real = neighbours.rebuild
    monkeypatch.setattr(neighbours, "rebuild", lambda *a: calls.append(1) or real(*a))
    for compiled in (True, False):
        sim.compiled = compiled
        build, pa = sim._pos_build.copy(), sim._pa.copy()
        sim.step(500)
        np.testing.assert_array_equal(sim._pos_build, build)
        np.testing.assert_array_equal(sim._pa, pa)
    assert calls == []  # the Python path's rebuilds (the compiled loop's call numba directly)
