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
    moved = displacement_since(sim.idx, s.pos, sim.pairs.pos_build, sim.geom, sim.periodic)
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
            np.testing.assert_array_equal(cp.pairs.pos_build, py.pairs.pos_build)
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


def drifting_lattice(integrator, compiled, speed, law="step_averaged"):
    """27 spheres on a lattice of spacing 2R + 2 skin (never within the skin of each other), all moving at
    *speed* along (1, 2, 2)/3: nothing touches, the list is rebuilt only for the displacement."""
    sim = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator, sleeping=False, contact_law=law)
    sim.compiled = compiled
    g = np.arange(3) * (2 * R + 0.2)
    pos = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    sim.add_particles(pos, R, ROCK, vel=np.tile(np.array([1.0, 2.0, 2.0]) / 3.0 * speed, (27, 1)))
    return sim


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("frac", [0.23, 0.5, 0.77])
@pytest.mark.parametrize("law", ["step_averaged", "hooke_history"])
def test_uniform_drift_rebuilds_once_per_half_skin(integrator, frac, law):
    """A uniform drift of ``s`` per step: the list is rebuilt at the end of every m-th step's drift, m the
    least with ``m s + reach > skin/2`` (reach: ``dt/2 |v| = s/2`` for the step-averaged law, 0 for
    ``hooke_history``), and at no other step: the build positions change exactly at steps m, 2m, ...
    (Python path, each step) and, in the compiled loop (one call), are those of the last multiple of m."""
    probe = drifting_lattice(integrator, False, 1.0)
    skin, dt = probe.skin, probe.dt
    m = 6
    reach = 0.5 if law == "step_averaged" else 0.0  # in units of s
    s = 0.5 * skin / (m - 1 + frac + reach)  # (m - 1) s + reach < skin/2 < m s + reach
    assert (m - 1 + reach) * s < 0.5 * skin < (m + reach) * s
    nsteps = 5 * m + 3
    py = drifting_lattice(integrator, False, s / dt, law)
    py.step(1)  # the first step builds at the start positions
    builds = []
    for n in range(2, nsteps + 1):
        before = py.pairs.pos_build.copy()
        py.step(1)
        if not np.array_equal(before, py.pairs.pos_build):
            builds.append(n)
        moved = displacement_since(py.idx, py.state.pos, py.pairs.pos_build, py.geom, py.periodic)
        assert moved <= 0.5 * skin, f"step {n}: forces evaluated {moved:.6g} m from the build"
    assert builds == list(range(m, nsteps + 1, m))
    cp = drifting_lattice(integrator, True, s / dt, law)
    cp.step(nsteps)
    last = nsteps - nsteps % m
    start = drifting_lattice(integrator, False, s / dt, law).state.pos
    v = np.array([1.0, 2.0, 2.0]) / 3.0 * s
    np.testing.assert_allclose(cp.pairs.pos_build, start + last * v, rtol=0, atol=1e-3 * s)
    np.testing.assert_array_equal(cp.pairs.pos_build, py.pairs.pos_build)
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
    assert v < 1e-4 and sim.n_contacts == 25 and sim.pairs.pa.size == 40  # at rest on the floor
    calls = []
    from breachflow.dem import neighbours

    real = neighbours.rebuild
    monkeypatch.setattr(neighbours, "rebuild", lambda *a: calls.append(1) or real(*a))
    for compiled in (True, False):
        sim.compiled = compiled
        build, pa = sim.pairs.pos_build.copy(), sim.pairs.pa.copy()
        sim.step(500)
        np.testing.assert_array_equal(sim.pairs.pos_build, build)
        np.testing.assert_array_equal(sim.pairs.pa, pa)
    assert calls == []  # the Python path's rebuilds (the compiled loop's call numba directly)


# The step-averaged law looks max(-lo, hi) |v_rel . n| = s ahead (velocity Verlet interval [-dt/2, dt/2], two
# spheres closing at 2 s per step): a pair apart by less than s gets the force of the part of the interval in
# contact. An unlisted pair can be there while each sphere moved no more than skin/2 since the build: the
# rebuild decision is ``moved + reach > skin/2`` with reach = max(-lo, hi) max|v| (dem/pairlist.py
# ``relist_after_drift``), each sphere's own reach within its half of the skin.

def interval_onset(integrator, k, f, c, direction, shift, compiled, skin=None):
    """Two spheres approaching head-on at ``s`` per step each, ``s = (skin/2) / (k + f)`` (``f < 1/2``):
    after step k each moved ``k s = skin/2 - f s`` (under skin/2: no rebuild for the displacement alone)
    and, with the gap at the build ``skin + c (1 - 2 f) s``, their gap is ``(2 f + c (1 - 2 f)) s``, in
    (0, s): not touching, but within the interval's reach. *skin* None: the default (0.1 m, the pair unlisted
    at the build); else that skin (the same start and dt): the always-listed reference. Returns (sim, e, s)."""
    probe = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator)
    probe.add_particles([[0.0, 0.0, 0.0]], R, ROCK)
    skin0, dt = probe.skin, probe.dt
    s = 0.5 * skin0 / (k + f)
    gap = skin0 + c * (1.0 - 2.0 * f) * s
    e = np.asarray(direction, float) / np.linalg.norm(direction)
    x0 = np.asarray(shift, float)
    sim = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator, skin=skin, dt=dt)
    sim.compiled = compiled
    sim.add_particles([x0, x0 + e * (2 * R + gap)], R, ROCK, vel=[e * (s / dt), -e * (s / dt)])
    assert sim.dt == dt and sim.skin == (skin0 if skin is None else skin)
    return sim, e, s


INTERVAL_CASES = [(k, f, c, d, sh) for k in (3, 7, 19) for f in (0.02, 0.2, 0.35, 0.48) for c, d, sh in
                ((0.5, (1, 0, 0), (0.0, 0.0, 0.0)), (0.9, (1, 1, 1), (0.37, -1.21, 2.53)),
                 (0.1, (0, 0.6, -0.8), (5.1, 0.0, 0.0)))]


def unlisted_within_reach(sim, vel):
    """Whether the (only) pair is unlisted while the step-averaged law would give it a force: its gap positive and
    below ``max(-lo, hi) |v_rel . n|`` (*vel*: the velocities the law uses)."""
    s = sim.state
    d = s.pos[1] - s.pos[0]
    dist = np.linalg.norm(d)
    gap = dist - 2 * R
    reach = 0.5 * sim.dt * abs((vel[1] - vel[0]) @ d / dist)
    return sim.pairs.pa.size == 0 and 0.0 < gap < reach


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("k,f,c,direction,shift", INTERVAL_CASES)
def test_a_pair_within_the_interval_reach_gets_its_partial_force_python_path(integrator, k, f, c, direction, shift):
    """Python path, one step at a time, against the same start with skin 1 m (the pair listed from the first
    step, so the lists are the only difference): the pair's forces, positions and velocities are the same
    bit for bit at every step, including step k, the first with a contact force (gap in (0, s): a
    partial-interval force); the pair is never unlisted within the interval's reach."""
    sim, e, s = interval_onset(integrator, k, f, c, direction, shift, compiled=False)
    ref, _, _ = interval_onset(integrator, k, f, c, direction, shift, compiled=False, skin=1.0)
    first = None
    for n in range(1, k + 6):
        sim.step(1)
        ref.step(1)
        assert ref.pairs.pa.size == 1  # the reference lists the pair all along
        assert not unlisted_within_reach(sim, sim.work["v"] if integrator == "predicted_verlet" else sim.state.vel)
        np.testing.assert_array_equal(sim.force, ref.force, err_msg=f"step {n}")
        np.testing.assert_array_equal(sim.state.pos, ref.state.pos, err_msg=f"step {n}")
        np.testing.assert_array_equal(sim.state.vel, ref.state.vel, err_msg=f"step {n}")
        gap = np.linalg.norm(ref.state.pos[1] - ref.state.pos[0]) - 2 * R
        if first is None and ref.force[0] @ e != 0.0:
            first = n
            assert 0.0 < gap < s  # the onset is a interval-only one: not touching at the evaluation
            assert ref.force[0] @ e < 0.0 < ref.force[1] @ e
    assert first == k


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("k,f,c,direction,shift", INTERVAL_CASES[::2])
def test_a_pair_within_the_interval_reach_gets_its_partial_force_compiled_loop(integrator, k, f, c, direction,
                                                                            shift):
    """The compiled loop (one call after the first Python step), fresh for each n, against the always-listed
    reference run the same way: the same forces, positions and velocities bit for bit at the interval-only
    onset (step k) and after it."""
    for n in (k, k + 1, k + 4):
        sim, e, s = interval_onset(integrator, k, f, c, direction, shift, compiled=True)
        ref, _, _ = interval_onset(integrator, k, f, c, direction, shift, compiled=True, skin=1.0)
        sim.step(n)
        ref.step(n)
        assert sim.steps == ref.steps == n
        if n == k:
            gap = np.linalg.norm(ref.state.pos[1] - ref.state.pos[0]) - 2 * R
            assert 0.0 < gap < s and ref.force[0] @ e < 0.0  # the interval-only onset
        np.testing.assert_array_equal(sim.force, ref.force, err_msg=f"step {n}")
        np.testing.assert_array_equal(sim.state.pos, ref.state.pos, err_msg=f"step {n}")
        np.testing.assert_array_equal(sim.state.vel, ref.state.vel, err_msg=f"step {n}")


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("law", ["step_averaged", "hooke_history"])
def test_the_reach_rebuild_is_the_step_averaged_laws_only(integrator, law):
    """One sphere approaching another at rest until it has moved just under skin/2 while its reach
    (``dt/2 |v|``) takes it over: the step-averaged law rebuilds at that step, ``hooke_history`` (point values,
    reach 0) does not; both paths alike."""
    for compiled in (False, True):
        probe = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator)
        probe.add_particles([[0.0, 0.0, 0.0]], R, ROCK)
        skin, dt = probe.skin, probe.dt
        k, f = 5, 0.3
        s = 0.5 * skin / (k + f)  # after step k: moved k s = skin/2 - 0.3 s, reach s/2
        sim = DemSimulation(gravity=(0.0, 0.0, 0.0), integrator=integrator, contact_law=law, sleeping=False)
        sim.compiled = compiled
        sim.add_particles([[0.0, 0.0, 0.0], [2 * R + 3 * skin, 0.0, 0.0]], R, ROCK, vel=[[s / dt, 0, 0], [0, 0, 0]])
        sim.step(1)
        x_build = sim.pairs.pos_build[0, 0]
        sim.step(k - 1)
        rebuilt = sim.pairs.pos_build[0, 0] != x_build
        assert rebuilt == (law == "step_averaged"), (compiled, sim.pairs.pos_build[0, 0] - x_build)
