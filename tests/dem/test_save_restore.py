"""save_state / from_state: N steps + save + restore + M steps is bit-identical to N + M steps."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, HeightField, Material, ParticleState, Plane, sphere_mass
from breachflow.coupling.integrators import AdaptiveFreeFlight
from breachflow.errors import InputError
from breachflow.fluid.forces import FluidForces

R = 0.3
KN = 1e7
M = float(sphere_mass(R, 2650.0))


class Flow:
    def added_mass(self, state):
        return 0.5 * state.mass

    def accumulate(self, state, pos, vel, omega, t, force, torque):
        force[:, 0] += 0.01 * state.mass * 9.8
        force[:] -= 30.0 * vel


def scene():
    mat = Material(kn=KN, friction=0.6, rolling_friction=0.3, c_cn=2 * 0.3 * math.sqrt(KN * M / 2), c_cs=200.0,
                   c_cf=100.0, c_gn=50.0, c_gw=5.0)
    x = np.linspace(-4, 4, 9)
    boundaries = [HeightField(x, x, 0.02 * np.add.outer(x, x), mat),
                  Plane((2.0, 0, 0), (-1, 0, 0), mat, control="velocity", velocity=(-0.05, 0.0, 0.0)),
                  Plane((-3.0, 0, 0), (1, 0, 0), mat)]
    return boundaries, [Flow()], dict(sleep_steps=20, sleep_check=5, sleep_velocity=2e-3,
                                      domain=(-5, 5, -5, 5, -5, 20))


def build(integrator):
    boundaries, models, kw = scene()
    sim = DemSimulation(boundaries=boundaries, models=models, integrator=integrator, **kw)
    rng = np.random.default_rng(11)
    pos = np.column_stack([rng.uniform(-1.2, 1.2, 40), rng.uniform(-1.2, 1.2, 40), rng.uniform(0.5, 5.0, 40)])
    pos = pos[np.argsort(pos[:, 2])]
    keep = [0]
    for i in range(1, len(pos)):  # no initial overlaps
        if np.min(np.linalg.norm(pos[keep] - pos[i], axis=1)) > 2.05 * R:
            keep.append(i)
    sim.add_particles(pos[keep], R * rng.uniform(0.8, 1.2, len(keep)), boundaries[0].material,
                      vel=rng.normal(0, 0.5, (len(keep), 3)))
    return sim


def settle_and_sleep(sim) -> int:
    """2000 steps, then on until two particles touch with a rolling history; then the cycle's use: the
    lower masses go to sleep, and so do the touching pairs (so that histories are parked whatever the
    trajectory). Returns the steps taken."""
    sim.step(2000)
    for _ in range(5000):
        pairs = sim.pairs.touch & np.any(sim.pairs.rhist != 0.0, axis=1)
        if pairs.any():
            break
        sim.step()
    sim.sleep(np.union1d(np.flatnonzero(sim.state.pos[:, 2] < 1.0), np.r_[sim.pairs.pa[pairs], sim.pairs.pb[pairs]]))
    return sim.steps


@pytest.mark.parametrize("integrator", ["predicted_verlet", "report"])
def test_save_restore_continues_bit_identically(integrator, tmp_path):
    ref = build(integrator)
    k = settle_and_sleep(ref)
    n_steps, m_steps = k + 150, 1500
    ref.step(n_steps + m_steps - k)

    sim = build(integrator)
    assert settle_and_sleep(sim) == k
    sim.step(n_steps - k)
    assert (~sim.state.awake & sim.state.active).any() and sim.state.awake.any()
    assert sim.pairs.frozen_keys.size > 0 and np.abs(sim.pairs.frozen_hist[:, 3:]).max() > 0  # parked rolling histories
    path = tmp_path / "dem.npz"
    np.savez(path, **sim.save_state())
    sim.step(3)  # the original keeps going: the saved copy must not change
    boundaries, models, kw = scene()
    with np.load(path) as data:
        back = DemSimulation.from_state(dict(data), boundaries=boundaries, models=models, integrator=integrator,
                                        **kw)
    assert back.steps == n_steps
    back.step(m_steps)
    assert back.steps == ref.steps and back.t == ref.t
    for name in ("pos", "vel", "omega", "awake", "active"):
        assert np.array_equal(getattr(back.state, name), getattr(ref.state, name)), name
    assert np.array_equal(back.pairs.hist, ref.pairs.hist) and np.array_equal(back.pairs.rhist, ref.pairs.rhist)
    assert np.array_equal(back.pairs.frozen_hist, ref.pairs.frozen_hist)
    for a, b in zip(back.boundaries, ref.boundaries):
        assert np.array_equal(a.hist, b.hist) and np.array_equal(a.rhist, b.rhist)
    assert back.particle_steps == ref.particle_steps and back.left_domain == ref.left_domain


def test_from_state_refuses_mismatched_boundaries():
    sim = build("predicted_verlet")
    sim.step(10)
    data = sim.save_state()
    boundaries, models, kw = scene()
    with pytest.raises(InputError, match="boundaries"):
        DemSimulation.from_state(data, boundaries=boundaries[:2], models=models, **kw)
    with pytest.raises(InputError, match="kind"):
        DemSimulation.from_state(data, boundaries=[boundaries[1], boundaries[0], boundaries[2]], models=models,
                                 **kw)
    del data["state.pos"]
    with pytest.raises(InputError, match="state.pos"):
        DemSimulation.from_state(data, boundaries=boundaries, models=models, **kw)


def continued(make, n_steps, m_steps, tmp_path):
    """(uninterrupted N + M steps, N steps + save to .npz + restore + M steps); *make()* -> (sim, from_state kw)."""
    ref, _ = make()
    ref.step(n_steps + m_steps)
    sim, kw = make()
    sim.step(n_steps)
    path = tmp_path / "dem.npz"
    np.savez(path, **sim.save_state())
    sim.step(3)  # the original keeps going: the saved copy must not change
    with np.load(path) as data:
        back = DemSimulation.from_state(dict(data), **make()[1])
    back.step(m_steps)
    assert back.steps == ref.steps and back.t == ref.t
    for name in ("pos", "vel", "omega", "vel_prev", "omega_prev"):
        assert np.array_equal(getattr(back.state, name), getattr(ref.state, name)), name
    return ref, back


def falling_onto_a_plane():
    """A rock thrown up 10 m above a plane, in air (drag: the error controller rejects steps), then bouncing."""
    mat = Material(kn=1e6, c_cn=2 * 0.3 * math.sqrt(1e6 * M))
    kw = dict(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], models=[FluidForces(None, velocity_profile="uniform")],
              integrator=AdaptiveFreeFlight(rtol=1e-8, atol=1e-10), sleeping=False)
    sim = DemSimulation(ParticleState.spheres([[0.0, 0.0, R + 10.0]], R, mat, vel=[[0.3, 0.0, 2.0]]), **kw)
    return sim, kw


def test_adaptive_free_flight_continues_bit_identically(tmp_path):
    """The step-size controller is saved: free flight resumes with the estimate of the uninterrupted run."""
    ref, back = continued(falling_onto_a_plane, 6, 60, tmp_path)
    integ = ref.integrator
    assert integ.rejected > 0 and integ.contact_steps > 0 and integ.free_steps > 20  # flight, contact, rebound
    assert back.integrator.h == integ.h
    for name in ("free_steps", "rejected", "contact_steps"):
        assert getattr(back.integrator, name) == getattr(integ, name), name
    # the saved estimate matters: a restarted controller takes other steps
    sim, kw = falling_onto_a_plane()
    sim.step(6)
    restarted = DemSimulation.from_state(sim.save_state(), **falling_onto_a_plane()[1])
    restarted.integrator.h = None
    restarted.step(60)
    assert restarted.t != ref.t


def settling(integrator="predicted_verlet", basset=True):
    """A 2 mm steel sphere settling from rest in still water (surface at z = 0)."""
    model = FluidForces(0.0, air=None, basset=basset, velocity_profile="uniform")
    kw = dict(models=[model], integrator=integrator, dt=1e-4, sleeping=False)
    state = ParticleState.spheres([[0.0, 0.0, -0.5], [0.1, 0.0, -0.5]], [1e-3, 2e-3],
                                  Material(density=7800.0, kn=1e-3))
    return DemSimulation(state, **kw), kw


@pytest.mark.parametrize("integrator", ["predicted_verlet", "adaptive_free_flight"])
def test_basset_history_continues_bit_identically(integrator, tmp_path):
    """The Basset history (near history and exponential tail) is saved and restored into the model passed again."""
    ref, back = continued(lambda: settling(integrator), 30, 30, tmp_path)
    h_ref, h_back = ref.models[0].basset, back.models[0].basset
    assert np.abs(h_ref.z).max() > 0  # the tail holds history
    for name in ("t_hist", "r_hist", "z", "known"):
        assert np.array_equal(getattr(h_back, name), getattr(h_ref, name)), name
    # the history force matters: without it the sphere is elsewhere
    plain, _ = settling(integrator, basset=False)
    plain.step(60)
    assert not np.array_equal(plain.state.vel, ref.state.vel)


def test_from_state_refuses_a_mismatched_basset_setting():
    on, _ = settling(basset=True)
    on.step(5)
    off, _ = settling(basset=False)
    off.step(5)
    with pytest.raises(InputError, match=r"model0\.basset\.z.*basset=False"):
        DemSimulation.from_state(on.save_state(), **settling(basset=False)[1])
    with pytest.raises(InputError, match=r"lacks.*model0\.basset\.z.*basset=True"):
        DemSimulation.from_state(off.save_state(), **settling(basset=True)[1])
    with pytest.raises(InputError, match=r"model0\.basset\.z.*beyond the 0 given"):
        DemSimulation.from_state(on.save_state(), **{**settling()[1], "models": []})


def test_from_state_refuses_a_mismatched_integrator():
    sim, kw = falling_onto_a_plane()
    sim.step(3)
    with pytest.raises(InputError, match=r"integrator\.h"):
        DemSimulation.from_state(sim.save_state(), **{**kw, "integrator": "predicted_verlet"})
