"""The skip paths of the compiled DEM loop (issue 16): the damping pass skipped when every coefficient is 0
(``steploop.any_damping`` / ``second_pass``) and ``hooke_history``'s apart test without velocities in the
pair and plane loops — at unfavourable cases: a sphere exactly at contact distance from the floor, spheres
and pairs touching and leaving (their histories cleared), damping on only some particles, both integrators
and both contact laws."""
import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, steploop
from breachflow.dem import pair_contacts as contacts
from breachflow.dem.contact_law import HOOKE_HISTORY, STEP_AVERAGED
from breachflow.dem.contact_law import contact_laws

from .test_steploop import assert_same

ROCK = Material(density=2650, kn=1e6, ks=1e6, friction=0.5, c_cn=2e3, c_cs=1e3, c_cf=1e3, rolling_friction=0.1)
R = 0.25


def scene(integrator, law, damping, compiled):
    """A floor and a tilted side plane; a sphere exactly at contact distance above the floor (z = r, moving
    down), one overlapping it and leaving upwards, one at contact distance moving up, and a column of
    spheres dropped onto them; global damping on *damping* ("none", "some c_gn", "some c_gw")."""
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK), Plane((-1.5, 0, 0), (1, 0, 0.3), ROCK)],
                        dt=5e-4, sleeping=False, integrator=integrator, contact_law=law,
                        domain=(-3, 3, -3, 3, -1, 30))
    sim.compiled = compiled
    rng = np.random.default_rng(7)
    n = 24
    pos = np.column_stack([rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n), 1.0 + 0.6 * np.arange(n) / 3])
    vel = rng.normal(0, 0.3, (n, 3))
    pos[0] = (0.0, 0.0, R)  # exactly at contact distance: overlap 0.25 - 0.25 = 0
    vel[0] = (0.0, 0.0, -0.4)
    pos[1] = (1.2, 1.2, R - 1e-3)  # touching now, leaving
    vel[1] = (0.1, 0.0, 2.0)
    pos[2] = (-1.0, 1.2, R)  # at contact distance, moving away
    vel[2] = (0.0, 0.0, 0.5)
    sim.add_particles(pos, R, ROCK, vel=vel)
    s = sim.state
    s.c_gn[:] = 0.0
    s.c_gw[:] = 0.0
    if damping == "some c_gn":
        s.c_gn[5::7] = 3.0 * s.mass[5::7]
    elif damping == "some c_gw":
        s.c_gw[1::9] = 3.0 * s.inertia[1::9]  # sphere 1 spins up sliding on the floor
    return sim


@pytest.mark.parametrize("law", ["step_averaged", "hooke_history"])
@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("damping", ["none", "some c_gn", "some c_gw"])
def test_fused_plane_pass_and_damping_skip_equal_the_python_step(integrator, law, damping, monkeypatch):
    """The compiled loop (damping pass skipped or not) gives the Python step's state, histories and plane
    reactions bit for bit (the Python step runs the damping pass always)."""
    calls = []
    real = steploop.run
    monkeypatch.setattr(steploop, "run", lambda *a, **k: calls.append(1) or real(*a, **k))
    ref = scene(integrator, law, damping, compiled=False)
    new = scene(integrator, law, damping, compiled=True)
    for n in (1, 3, 40, 600):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
        for a, b in zip(ref.boundaries, new.boundaries):
            for name in ("hist", "rhist", "reaction"):
                np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name, strict=True)
        assert ref.n_contacts == new.n_contacts
    assert len(calls) >= 3  # (the first step computes the start forces in Python)
    if damping == "none":
        assert not steploop.any_damping(new.idx, new.state.c_gn, new.state.c_gw)
    else:  # the damping acted: undamped, the damped particles move differently
        undamped = scene(integrator, law, "none", compiled=True)
        undamped.step(644)
        assert not np.array_equal(undamped.state.omega, new.state.omega)


def one_sphere_on_floor(z, vz, hist_row):
    """Arrays of plane_forces for one sphere of radius R at height *z* above the floor z = 0, velocity
    (0.2, 0, vz), shear and rolling histories set to *hist_row*."""
    m = ROCK
    props = np.array([[m.adhesion, m.friction, m.kn, m.ks_value, m.c_cn, m.c_cs, m.c_cf, m.rolling_friction]])
    pos = np.array([[0.0, 0.0, z]])
    vel = np.array([[0.2, 0.0, vz]])
    omega = np.zeros((1, 3))
    mass = np.array([2650 * 4 / 3 * np.pi * R**3])
    return dict(idx=np.zeros(1, np.int64), point=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]), wvel=np.zeros(3),
                wprops=props[0].copy(), hist=np.array([hist_row], float), rhist=np.array([hist_row], float), pos=pos,
                vel=vel, omega=omega, radius=np.array([R]), mass=mass, inertia=0.4 * mass * R**2, props=props,
                dt=1e-3, force=np.zeros((1, 3)), torque=np.zeros((1, 3)), reaction=np.zeros(3))


def call_plane(a, law, lo, hi):
    return contacts.plane_forces(a["idx"], a["point"], a["normal"], a["wvel"], a["wprops"], a["hist"], a["rhist"],
                                 a["pos"], a["vel"], a["omega"], a["radius"], a["mass"], a["inertia"], a["props"],
                                 a["dt"], a["force"], a["torque"], a["reaction"], lo, hi, a["vel"], a["omega"], law)


@pytest.mark.parametrize("vz", [-0.4, 0.0, 0.4])
def test_sphere_exactly_at_contact_distance(vz):
    """overlap = r - z = 0 exactly. hooke_history (point values): no contact, no force, histories cleared.
    Step-averaged law over [-dt/2, dt/2]: approaching or receding at 0.4 m/s it overlaps for half the
    interval, so the force is the law's (registry :class:`~breachflow.dem.contact_law.StepAveraged`) with
    phi = 1/2; at rest: none."""
    a = one_sphere_on_floor(R, vz, (1e-4, -2e-4, 0.0))
    assert call_plane(a, HOOKE_HISTORY, 0.0, 0.0) == 0
    assert not a["force"].any() and not a["torque"].any() and not a["reaction"].any()
    assert not a["hist"].any() and not a["rhist"].any()

    a = one_sphere_on_floor(R, vz, (0.0, 0.0, 0.0))
    dt = a["dt"]
    assert call_plane(a, STEP_AVERAGED, -0.5 * dt, 0.5 * dt) == 0  # not overlapping now
    h = np.zeros(3)
    phi, f, _, _ = contact_laws.get("step_averaged")().force(
        (0.0, 0.0, -1.0), 0.0, (-0.2, 0.0, -vz), (-0.2, 0.0, -vz), h, ROCK.kn, ROCK.ks_value, ROCK.c_cn, ROCK.c_cs,
        ROCK.c_cf, ROCK.adhesion, ROCK.friction, dt, -0.5 * dt, 0.5 * dt)
    if vz != 0.0:  # in contact over half the interval: after now (approaching) or before now (receding)
        assert phi == 0.5 and f[2] != 0.0
        np.testing.assert_array_equal(a["force"][0], f)
        np.testing.assert_array_equal(a["reaction"], -f)
    else:
        assert phi == 0.0 and not a["force"].any() and not a["reaction"].any()


@pytest.mark.parametrize("row", [(3e-5, 0.0, 0.0), (0.0, 0.0, -1e-9), (-0.0, 0.0, 0.0), (0.0, -0.0, 0.0),
                                 (0.0, 0.0, -0.0)])
@pytest.mark.parametrize("law", [STEP_AVERAGED, HOOKE_HISTORY])
def test_a_sphere_that_leaves_the_floor_has_its_histories_cleared_bit_for_bit(row, law):
    """Apart (z = r + 1 mm, receding): both history rows end as +0.0 in every bit, whatever they held
    (a shear or rolling history, or a signed zero)."""
    for which in ("hist", "rhist"):
        a = one_sphere_on_floor(R + 1e-3, 0.3, (0.0, 0.0, 0.0))
        a[which][0] = row
        dt = a["dt"]
        call_plane(a, law, -0.5 * dt, 0.5 * dt)
        for name in ("hist", "rhist"):
            assert not np.signbit(a[name]).any() and not a[name].any(), (which, name)
        assert not a["force"].any()


@pytest.mark.parametrize("row", [(3e-5, 0.0, 0.0), (0.0, -0.0, 0.0), (0.0, 0.0, -2e-7)])
@pytest.mark.parametrize("law", [STEP_AVERAGED, HOOKE_HISTORY])
@pytest.mark.parametrize("uniform", [True, False])
def test_a_pair_that_separates_has_its_histories_cleared_bit_for_bit(row, law, uniform):
    """Two listed spheres 1 mm apart and separating, with a shear or rolling history left from their
    contact: the pair loop clears both rows to +0.0 (one-material copy and the general one)."""
    for which in (0, 1):
        pos = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2 * R + 1e-3]])
        vel = np.array([[0.0, 0.0, -0.1], [0.0, 0.0, 0.1]])
        m = ROCK
        props = np.tile([m.adhesion, m.friction, m.kn, m.ks_value, m.c_cn, m.c_cs, m.c_cf, m.rolling_friction],
                        (2, 1))
        if not uniform:
            props[1, 1] = 0.4
        hist, rhist = np.zeros((1, 3)), np.zeros((1, 3))
        (hist, rhist)[which][0] = row
        touch = np.array([True])
        dt = 1e-3
        lo, hi = (-0.5 * dt, 0.5 * dt) if law == STEP_AVERAGED else (0.0, 0.0)
        force, torque = np.zeros((2, 3)), np.zeros((2, 3))
        n = contacts.pair_forces_interval(
            np.array([0]), np.array([1]), hist, rhist, touch, pos, vel, np.zeros((2, 3)), vel, np.zeros((2, 3)),
            False, np.full(2, R), np.ones(2), np.ones(2), props, np.ones(2, bool), np.ones(2, bool), np.zeros(8),
            np.zeros(2, np.int64), dt, 0.1, force, torque, np.zeros(2, bool), np.zeros(2, np.int64),
            np.zeros(1, np.int64), lo, hi, law)
        assert n == 0 and not touch[0] and not force.any() and not torque.any()
        for h in (hist, rhist):
            assert not np.signbit(h).any() and not h.any(), which
