"""The compiled pair loop (``contacts.pair_forces_interval``) against a plain-Python reference of the same loop.

The reference below is the pair loop written out in Python with 2-D indexing (``pos[j, 0]``), calling the
Python versions (``py_func``) of the contact laws; the compiled loop indexes flat views of the (N, 3)
arrays (``3 i + k``). Forces, torques, histories, contact flags, #contacts and woken particles must agree
to round-off (the compiled laws fuse ``a * b + c`` into one rounding): a wrong row, column or array in the
loop's indexing gives differences of the size of the values themselves. Random piles of
``test_pair_fast_path`` at both laws, split and plain velocities, periodic or not, one material (the
fast copy) and the general copy (mixed materials, a sleeping particle whose moving partner wakes it).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from breachflow.dem import contact_law as cl
from breachflow.dem import pair_contacts as contacts
from breachflow.dem.contact_law import HOOKE_HISTORY, STEP_AVERAGED

from .test_pair_fast_path import DT, random_pile


def _min_image(d, length, periodic):
    return d - length * math.floor(d / length + 0.5) if periodic else d


def reference_loop(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius, mass, inertia,
                   props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo, hi,
                   law):
    """``contacts._pair_loop`` in plain Python (general copy: properties as min of the partners')."""
    mr = np.empty(3)
    nc = 0
    reach_t = max(-lo, hi) if law == STEP_AVERAGED else 0.0
    for p in range(pa.shape[0]):
        i, j = int(pa[p]), int(pb[p])
        if not (awake[i] or awake[j]) or not (active[i] and active[j]):
            continue
        dx = _min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
        dy = _min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
        dz = pos[j, 2] - pos[i, 2]
        d2 = dx * dx + dy * dy + dz * dz
        ri, rj = radius[i], radius[j]
        rs = ri + rj
        gap2 = d2 - rs * rs
        if gap2 >= 0.0:
            if law == HOOKE_HISTORY:
                apart = True
            else:
                vd = reach_t * abs((vel[i, 0] - vel[j, 0]) * dx + (vel[i, 1] - vel[j, 1]) * dy
                                   + (vel[i, 2] - vel[j, 2]) * dz)
                apart = vd <= 0.5 * gap2 or (vd + (rs - math.sqrt(d2)) * math.sqrt(d2) <= 0.0)
            if apart:
                hist[p] = 0.0
                rhist[p] = 0.0
                touching[p] = False
                continue
        dist = math.sqrt(d2)
        overlap = rs - dist
        if dist > 1e-12 * rs:
            nx, ny, nz = dx / dist, dy / dist, dz / dist
        else:
            nx, ny, nz = 0.0, 0.0, 1.0
        w = ri * omega[i] + rj * omega[j]
        v = vel[j] - vel[i] - np.cross(w, [nx, ny, nz])
        g = v
        if split:
            w = ri * omega_h[i] + rj * omega_h[j]
            g = vel_h[j] - vel_h[i] - np.cross(w, [nx, ny, nz])
        q = np.minimum(props[i], props[j])
        if law == HOOKE_HISTORY:
            phi, fx, fy, fz, ftx, fty, ftz, fn = cl.hooke_history.py_func(
                nx, ny, nz, overlap, *v, *g, hist, p, q[2], q[3], q[4], q[5], q[0], q[1], dt)
        else:
            phi, fx, fy, fz, ftx, fty, ftz, fn = cl.contact_law.py_func(
                nx, ny, nz, overlap, *v, *g, hist, p, q[2], q[3], q[4], q[5], q[6], q[0], q[1], dt, lo, hi)
        touching[p] = overlap > 0.0
        if overlap <= 0.0:
            rhist[p] = 0.0
            if phi <= 0.0:
                continue
        else:
            nc += 1
        force[i] += (fx, fy, fz)
        force[j] -= (fx, fy, fz)
        c = np.cross([nx, ny, nz], [ftx, fty, ftz])
        torque[i] += ri * c
        torque[j] += rj * c
        if q[7] > 0.0 and overlap > 0.0:
            i_eff = 1.0 / (1.0 / (inertia[i] + mass[i] * ri * ri) + 1.0 / (inertia[j] + mass[j] * rj * rj))
            cl.rolling_law.py_func(nx, ny, nz, *(omega[i] - omega[j]), fn, ri * rj / (ri + rj), q[7], q[2], i_eff,
                                   rhist, p, dt, mr)
            torque[i] += mr
            torque[j] -= mr
        if awake[i] != awake[j]:
            m, s = (i, j) if awake[i] else (j, i)
            sp = np.linalg.norm(vel[m]) + radius[m] * np.linalg.norm(omega[m])
            if sp > wake_speed and not wake[s]:
                wake[s] = True
                wake_ids[n_wake[0]] = s
                n_wake[0] += 1
    return nc


def _run(fn, c, law, split, periodic, mixed):
    n = c["pos"].shape[0]
    props = c["props"].copy()
    awake = np.ones(n, bool)
    if mixed:  # the general copy: two materials, and sleeping particles (one of each pair's kind)
        props[::3, 2] *= 1.5
        props[1::4, 5] *= 0.5
        awake[::5] = False
    out = dict(hist=c["hist"].copy(), rhist=c["rhist"].copy(), touching=np.zeros(c["pa"].size, bool),
               force=np.zeros((n, 3)), torque=np.zeros((n, 3)), wake=np.zeros(n, bool),
               wake_ids=np.zeros(n, np.int64), n_wake=np.zeros(1, np.int64))
    lo, hi = (-0.5 * DT, 0.5 * DT) if law == STEP_AVERAGED else (0.0, 0.0)
    out["nc"] = fn(c["pa"], c["pb"], out["hist"], out["rhist"], out["touching"], c["pos"], c["vel"], c["omega"],
                   c["vel_h"], c["omega_h"], split, c["radius"], c["mass"], c["inertia"], props, awake,
                   np.ones(n, bool), c["geom"], np.array([periodic, periodic], np.int64), DT, 0.05, out["force"],
                   out["torque"], out["wake"], out["wake_ids"], out["n_wake"], lo, hi, law)
    return out


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("law, split", [(STEP_AVERAGED, True), (STEP_AVERAGED, False), (HOOKE_HISTORY, False)])
@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("mixed", [False, True])
def test_compiled_pair_loop_matches_the_python_reference(seed, law, split, periodic, mixed):
    c = random_pile(seed)
    got = _run(contacts.pair_forces_interval, c, law, split, periodic, mixed)
    ref = _run(reference_loop, c, law, split, periodic, mixed)
    assert got["nc"] == ref["nc"] > 50
    assert 0 < ref["touching"].sum() < c["pa"].size and np.any(ref["rhist"] != 0.0)
    if mixed:
        assert ref["n_wake"][0] > 0  # sleeping partners woken
    for k in ("touching", "wake", "n_wake", "wake_ids"):
        assert np.array_equal(got[k], ref[k]), k
    for k, scale in (("force", 1e7 * 0.1), ("torque", 1e7 * 0.1), ("hist", 1e-3), ("rhist", 1e3)):
        np.testing.assert_allclose(got[k], ref[k], rtol=1e-9, atol=1e-12 * scale, err_msg=k)
