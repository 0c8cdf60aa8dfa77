"""The pair loop's one-material fast path (``contacts.uniform_awake``): bit for bit the general path.

``contacts.pair_forces_interval`` runs a copy of its loop compiled for the case where every particle is awake
and active and all share one property row. These tests run the same random piles through both copies (the
general one reached by one extra particle, in no pair, that breaks the condition) and require identical
forces, torques, histories and contact flags; and check that mixed properties take the general path
(the pair's properties are the minimum of the partners', an analytic Hooke force).
"""
from __future__ import annotations

import numpy as np
import pytest

from breachflow.dem import pair_contacts as contacts
from breachflow.dem.contact_law import HOOKE_HISTORY, STEP_AVERAGED

DT = 1e-4


def random_pile(seed, n=150, side=4.0):
    """Overlapping spheres in a side^3 box with random velocities, spins and contact histories; the
    pairs (i < j) with gap < 0.1 m (brute force), sorted by i then j as the neighbour list is."""
    rng = np.random.default_rng(seed)
    radius = rng.uniform(0.35, 0.6, n)
    pos = rng.uniform(0.0, side, (n, 3))
    pa, pb = [], []
    for i in range(n):
        for j in range(i + 1, n):
            d = pos[j] - pos[i]
            d[:2] -= side * np.round(d[:2] / side)  # periodic in x and y
            if np.linalg.norm(d) < radius[i] + radius[j] + 0.1:
                pa.append(i)
                pb.append(j)
    npairs = len(pa)
    hist = rng.normal(0.0, 1e-4, (npairs, 3)) * (rng.random((npairs, 1)) < 0.7)  # some fresh contacts
    rhist = rng.normal(0.0, 10.0, (npairs, 3)) * (rng.random((npairs, 1)) < 0.7)
    vel = rng.normal(0.0, 2.0, (n, 3))
    omega = rng.normal(0.0, 3.0, (n, 3))
    vel_h = vel + rng.normal(0.0, 0.1, (n, 3))
    omega_h = omega + rng.normal(0.0, 0.1, (n, 3))
    mass = 2650.0 * 4.0 / 3.0 * np.pi * radius**3
    inertia = 0.4 * mass * radius**2
    row = np.array([rng.uniform(0.0, 50.0), 0.5, 1e7, 0.8e7, 3e3, 1.5e3, 1e4, 0.1])  # adhesion..rolling_friction
    props = np.tile(row, (n, 1))
    geom = np.zeros(8)
    geom[6:8] = side
    return dict(pa=np.array(pa, np.int64), pb=np.array(pb, np.int64), hist=hist, rhist=rhist, pos=pos, vel=vel,
                omega=omega, vel_h=vel_h, omega_h=omega_h, radius=radius, mass=mass, inertia=inertia, props=props,
                geom=geom)


def run(c, law, split, periodic, extra=None):
    """pair_forces_interval on copies of pile *c*; *extra*: one more particle (in no pair) with these
    (awake, active, property row). Returns every array the kernel writes, and #contacts."""
    n = c["pos"].shape[0]
    m = n + (extra is not None)

    def grow(a, fill):
        return np.concatenate([a, np.full((1,) + a.shape[1:], fill, a.dtype)]) if extra is not None else a.copy()

    awake = np.ones(m, bool)
    active = np.ones(m, bool)
    props = grow(c["props"], 0.0)
    if extra is not None:
        awake[n], active[n], props[n] = extra[0], extra[1], extra[2]
    arrs = {k: grow(c[k], 100.0 if k == "pos" else 1.0) for k in ("pos", "vel", "omega", "vel_h", "omega_h",
                                                                   "radius", "mass", "inertia")}
    hist, rhist = c["hist"].copy(), c["rhist"].copy()
    touching = np.zeros(c["pa"].size, bool)
    force = np.zeros((m, 3))
    torque = np.zeros((m, 3))
    wake = np.zeros(m, bool)
    wake_ids = np.zeros(m, np.int64)
    n_wake = np.zeros(1, np.int64)
    lo, hi = (-0.5 * DT, 0.5 * DT) if law == STEP_AVERAGED else (0.0, 0.0)
    nc = contacts.pair_forces_interval(c["pa"], c["pb"], hist, rhist, touching, arrs["pos"], arrs["vel"], arrs["omega"],
                                     arrs["vel_h"], arrs["omega_h"], split, arrs["radius"], arrs["mass"],
                                     arrs["inertia"], props, awake, active, c["geom"],
                                     np.array([periodic, periodic], np.int64), DT, 0.05, force, torque, wake, wake_ids,
                                     n_wake, lo, hi, law)
    return dict(force=force[:n], torque=torque[:n], hist=hist, rhist=rhist, touching=touching, nc=nc,
                n_wake=n_wake[0])


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("law, split", [(STEP_AVERAGED, True), (STEP_AVERAGED, False), (HOOKE_HISTORY, False)])
@pytest.mark.parametrize("periodic", [True, False])
def test_fast_path_is_bitwise_the_general_path(seed, law, split, periodic):
    c = random_pile(seed)
    row = c["props"][0]
    yes = np.ones(c["props"].shape[0], bool)
    assert contacts.uniform_awake(c["props"], yes, yes)
    fast = run(c, law, split, periodic)
    assert fast["nc"] > 50 and 0 < fast["touching"].sum() < c["pa"].size  # contacts and listed pairs apart
    assert np.any(fast["rhist"] != 0.0)  # rolling resistance exercised
    # the general path: one extra particle, in no pair, asleep / inactive / of another material
    for extra in ((False, True, row), (True, False, row), (True, True, row * 1.5)):
        general = run(c, law, split, periodic, extra)
        for k, v in fast.items():
            assert np.array_equal(v, general[k]), (extra[:2], k)


def test_uniform_awake_detects_the_fast_path_case():
    props = np.tile(np.arange(8.0), (5, 1))
    yes = np.ones(5, bool)
    assert contacts.uniform_awake(props, yes, yes)
    assert not contacts.uniform_awake(props[:0], yes[:0], yes[:0])  # no particles
    for k in range(8):  # any column differs
        p = props.copy()
        p[3, k] += 1.0
        assert not contacts.uniform_awake(p, yes, yes), k
    one = yes.copy()
    one[4] = False
    assert not contacts.uniform_awake(props, one, yes)  # one asleep
    assert not contacts.uniform_awake(props, yes, one)  # one inactive
    p = props.copy()
    p[2, 1] = np.nan
    assert not contacts.uniform_awake(p, yes, yes)
    p = props.copy()
    p[:, 0] = 0.0
    p[3, 0] = -0.0  # equal as floats, but min(0.0, -0.0) depends on the order: not one row bit for bit
    assert not contacts.uniform_awake(p, yes, yes)
    assert contacts.uniform_awake(np.asfortranarray(props), yes, yes)  # any memory layout


@pytest.mark.parametrize("law", [STEP_AVERAGED, HOOKE_HISTORY])
def test_mixed_materials_take_the_softer_partners_stiffness(law):
    """Two spheres at rest overlapping by u: the normal force is min(k_N) u (Hooke), whichever partner is
    the stiffer one; the fast path with row 0's stiffness would give the stiffer value."""
    u = 1e-3
    for stiff in (0, 1):
        props = np.zeros((2, 8))
        props[:, 1] = 0.5
        props[:, 2:6] = 1e7, 1e7, 0.0, 0.0
        props[stiff, 2] = 3e7
        pos = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0 - u]])
        zero = np.zeros((2, 3))
        f = np.zeros((2, 3))
        t = np.zeros((2, 3))
        one = np.ones(2)
        lo, hi = (-0.5 * DT, 0.5 * DT) if law == STEP_AVERAGED else (0.0, 0.0)
        nc = contacts.pair_forces_interval(np.array([0]), np.array([1]), np.zeros((1, 3)), np.zeros((1, 3)),
                                         np.zeros(1, bool), pos, zero, zero, zero, zero, False, np.full(2, 0.5), one,
                                         one, props, np.ones(2, bool), np.ones(2, bool), np.zeros(8),
                                         np.zeros(2, np.int64), DT, 1e9, f, t, np.zeros(2, bool),
                                         np.zeros(2, np.int64), np.zeros(1, np.int64), lo, hi, law)
        assert nc == 1
        np.testing.assert_allclose(f[0], [0.0, 0.0, -1e7 * u], rtol=1e-9)
        np.testing.assert_allclose(f[1], [0.0, 0.0, 1e7 * u], rtol=1e-9)
