"""Many DEM steps per compiled call (dem/steploop.py, issue 16) give bit-identical results to stepping in
Python: same state, histories, sleep bookkeeping, retired particles and equilibrium outcome."""
import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, steploop
from breachflow.dem.pairlist import PairList

ROCK = Material(density=2650, kn=1e6, ks=1e6, friction=0.5, c_cn=2e3, c_cs=1e3, c_cf=1e3)
ROLLING = Material(density=2650, kn=1e6, ks=1e6, friction=0.5, c_cn=2e3, c_cs=1e3, c_cf=1e3,
                   rolling_friction=0.1)


def drop(integrator, *, sleeping, periodic, compiled, seed=3):
    """Spheres of two sizes (some with rolling friction) dropped onto two planes (a floor and a tilted
    side), some thrown out of the domain; periodic in y or a closed box."""
    rng = np.random.default_rng(seed)
    kw = dict(periodic_y=(-3.0, 3.0)) if periodic else {}
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK), Plane((-2.5, 0, 0), (1, 0, 0.3), ROCK)],
                        dt=5e-4, sleeping=sleeping, integrator=integrator, domain=(-3, 3, -3, 3, -1, 30), **kw)
    sim.compiled = compiled
    n = 40
    pos = np.column_stack([rng.uniform(-1.8, 1.8, n), rng.uniform(-1.8, 1.8, n), 0.5 + 0.9 * np.arange(n) / 4])
    vel = rng.normal(0, 0.5, (n, 3))
    vel[:3, 0] = 40.0  # these leave the domain (retired)
    sim.add_particles(pos[: n // 2], 0.2, ROCK, vel=vel[: n // 2])
    sim.add_particles(pos[n // 2:], 0.15, ROLLING, vel=vel[n // 2:])
    sim.state.c_gn[:] = 2.0 * sim.state.mass  # global damping: the pile comes to rest (sleeps)
    sim.state.c_gw[:] = 2.0 * sim.state.inertia
    return sim


def assert_same(a, b):
    sa, sb = a.save_state(), b.save_state()
    assert sa.keys() == sb.keys()
    for k in sa:
        np.testing.assert_array_equal(sa[k], sb[k], err_msg=k, strict=True)
    assert a.left_domain == b.left_domain and a.particle_steps == b.particle_steps and a.t == b.t


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("sleeping,periodic", [(False, True), (True, False)])
def test_compiled_steps_are_bit_identical(integrator, sleeping, periodic, monkeypatch):
    calls = []
    real = steploop.run
    monkeypatch.setattr(steploop, "run", lambda *a, **k: calls.append(1) or real(*a, **k))
    ref = drop(integrator, sleeping=sleeping, periodic=periodic, compiled=False)
    new = drop(integrator, sleeping=sleeping, periodic=periodic, compiled=True)
    for n in (1, 7, 1500, 3000):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
    assert len(calls) > 0 and ref.steps == new.steps == 4508
    assert len(new.left_domain) >= 3
    r_ref = ref.run_to_equilibrium(1e-5, max_steps=40000)
    r_new = new.run_to_equilibrium(1e-5, max_steps=40000)
    assert r_ref == r_new
    assert_same(ref, new)
    if sleeping:
        assert r_new.converged and not new.state.awake[new.state.active].all()  # sleep transitions exercised


def test_ineligible_scenes_step_in_python(monkeypatch):
    """Force models, the report scheme or a moving plane are stepped in Python."""
    sim = drop("report", sleeping=False, periodic=True, compiled=True)
    assert not steploop.eligible(sim)
    sim = drop("velocity_verlet", sleeping=False, periodic=True, compiled=True)
    sim.step(1)
    assert steploop.eligible(sim)
    sim.boundaries.append(Plane((0, 0, 5), (0, 0, -1), ROCK, control="velocity", velocity=(0, 0, -0.1)))
    assert not steploop.eligible(sim)


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("seed,sleep_check", [(3, 25), (5, 7), (11, 1)])
def test_rebuilds_while_particles_sleep_run_inside_the_compiled_call(integrator, seed, sleep_check, monkeypatch):
    """With sleepers, the neighbour-list rebuilds between events (sleep, wake, retirement) run inside the
    compiled call: the driver rebuilds in Python only at those events (sleeping grid out of date), while
    the step-by-step path rebuilds with sleepers present many times; states, lists and histories stay
    bit-identical to that path at several seeds and sleep-check phases."""
    py_rebuilds = {}
    real = PairList.rebuild

    def counted(self):
        between_events = not self.sleep_grid_dirty and (self.sim.state.active & ~self.sim.state.awake).any()
        py_rebuilds[id(self.sim)] = py_rebuilds.get(id(self.sim), 0) + between_events
        return real(self)

    monkeypatch.setattr(PairList, "rebuild", counted)
    ref = drop(integrator, sleeping=True, periodic=False, compiled=False, seed=seed)
    new = drop(integrator, sleeping=True, periodic=False, compiled=True, seed=seed)
    for sim in (ref, new):
        sim.sleep_check = sleep_check
    for n in (1, 700, 2500, 2000):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
    r_ref = ref.run_to_equilibrium(1e-5, max_steps=30000)
    r_new = new.run_to_equilibrium(1e-5, max_steps=30000)
    assert r_ref == r_new
    assert_same(ref, new)
    assert py_rebuilds[id(ref)] >= 12  # the scene rebuilds with sleepers present between events ...
    # ... which the compiled loop does inside the call: in Python at most at the start of each of the 5
    # driver calls (one that stopped at its step count just before a rebuild leaves it to the next)
    assert py_rebuilds.get(id(new), 0) <= 5
