"""The compiled boundary contact loops (``walls.plane_forces``, ``walls.heightfield_forces``) against a
plain-Python reference, bit for bit.

The reference is the boundary contact written out in Python with whole-row numpy arithmetic where it is
exact and the scalar order of docs/theory.md, *DEM contact* formulas elsewhere, calling the Python versions (``py_func``) of the
contact laws and of the rolling law; properties are ``min(particle's value, boundary's value)`` (Python's
``min``, the same selection as numba's). The compiled loops are built without fast-math, so forces,
torques, histories, the plane's reaction and #contacts must agree in every bit. Cases: both laws, split and
plain velocities, a fixed and a moving tilted plane, mixed property rows with signed zeros and rolling
friction > 0 on some rows (and 0 on others), histories with signed zeros, contacts that begin or end inside
the force interval (overlap of either sign with the normal speed's reach), particles far from the plane, an
index list in random order (a subset), a non-zero starting reaction; the height field with slopes,
particles outside the grid, near-grazing and overlapping ones.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from breachflow.dem import contact_law as cl
from breachflow.dem import wall_contacts as walls
from breachflow.dem.contact_law import HOOKE_HISTORY, STEP_AVERAGED

DT = 1e-3
BASE = np.array([0.0, 0.5, 1e7, 1e7, 3.6e4, 1.8e4, 1.8e4, 0.1])  # alpha, mu, kn, ks, c_cn, c_cs, c_cf, mu_r


def _contact(i, n, overlap, u, hist, rhist, vel, omega, vel_h, omega_h, radius, mass, inertia, q, wp, dt, lo, hi,
             law, force, torque):
    """One boundary contact (n from the centre towards the boundary, u its velocity); returns (phi, f) or
    (phi, None) if no force is added."""
    ri = radius[i]
    v = u - vel[i] - np.cross(ri * omega[i], n)
    g = u - vel_h[i] - np.cross(ri * omega_h[i], n)
    p = [min(q[k], wp[k]) for k in range(8)]
    if law == HOOKE_HISTORY:
        phi, fx, fy, fz, ftx, fty, ftz, fn = cl.hooke_history.py_func(
            *n, overlap, *v, *g, hist, i, p[2], p[3], p[4], p[5], p[0], p[1], dt)
    else:
        phi, fx, fy, fz, ftx, fty, ftz, fn = cl.contact_law.py_func(
            *n, overlap, *v, *g, hist, i, p[2], p[3], p[4], p[5], p[6], p[0], p[1], dt, lo, hi)
    if overlap <= 0.0:
        rhist[i] = 0.0
        if phi <= 0.0:
            return phi, None
    force[i] += (fx, fy, fz)
    nx, ny, nz = n
    torque[i, 0] += ri * (ny * ftz - nz * fty)
    torque[i, 1] += ri * (nz * ftx - nx * ftz)
    torque[i, 2] += ri * (nx * fty - ny * ftx)
    if p[7] > 0.0 and overlap > 0.0:
        mr = np.empty(3)
        cl.rolling_law.py_func(*n, *omega[i], fn, ri, p[7], p[2], inertia[i] + mass[i] * ri * ri, rhist, i, dt, mr)
        torque[i] += mr
    return phi, (fx, fy, fz)


def reference_plane(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt,
                    force, torque, reaction, lo, hi, vel_h, omega_h, law):
    reach_t = max(-lo, hi) if law == STEP_AVERAGED else 0.0
    nc = 0
    for i in map(int, idx):
        dist = ((pos[i, 0] - point[0]) * normal[0] + (pos[i, 1] - point[1]) * normal[1]
                + (pos[i, 2] - point[2]) * normal[2])
        overlap = radius[i] - dist
        vn = (vel[i, 0] - wvel[0]) * normal[0] + (vel[i, 1] - wvel[1]) * normal[1] + (vel[i, 2] - wvel[2]) * normal[2]
        if overlap <= 0.0 and (law == HOOKE_HISTORY or overlap + reach_t * abs(vn) <= 0.0):
            hist[i] = 0.0
            rhist[i] = 0.0
            continue
        nc += overlap > 0.0
        phi, f = _contact(i, -normal, overlap, wvel, hist, rhist, vel, omega, vel_h, omega_h, radius, mass, inertia,
                          props[i], wprops, dt, lo, hi, law, force, torque)
        if phi > 0.0:
            reaction[0] -= f[0]
            reaction[1] -= f[1]
            reaction[2] -= f[2]
    return nc


def reference_terrain_contacts(x0, y0, hx, hy, bed, c, r, v, reach_t):
    """The terrain's contacts of a sphere by the rule of ``walls.terrain_contacts``, written out: per patch
    under the footprint, the nearest point (three steps to the tangent plane's foot, kept on the patch); faces
    deepest first unless within 15 degrees of one taken; then the one deepest edge deeper than every face taken
    and not within 15 degrees of a contact taken; the most upward normal first. Rows (normal, overlap)."""
    nyb, nxb = bed.shape
    xmax, ymax = x0 + (nxb - 1) * hx, y0 + (nyb - 1) * hy
    if not (x0 <= c[0] <= xmax and y0 <= c[1] <= ymax):
        return []
    cols = range(min(max(math.floor((c[0] - r - x0) / hx), 0), nxb - 2), min(max(math.floor((c[0] + r - x0) / hx), 0), nxb - 2) + 1)
    rows = range(min(max(math.floor((c[1] - r - y0) / hy), 0), nyb - 2), min(max(math.floor((c[1] + r - y0) / hy), 0), nyb - 2) + 1)
    assert len(cols) <= 6 and len(rows) <= 6  # the case's footprints fit the kernel's scratch
    above = c[2] >= walls._bilinear.py_func(x0, y0, hx, hy, bed, c[0], c[1])[0]
    found = []
    for iy in rows:
        for ix in cols:
            lo_, hi_ = np.array([x0 + ix * hx, y0 + iy * hy]), np.array([x0 + ix * hx + hx, y0 + iy * hy + hy])
            s = np.minimum(np.maximum(c[:2], lo_), hi_)
            for _ in range(3):
                z, gx, gy = walls._patch.py_func(x0, y0, hx, hy, bed, ix, iy, s[0], s[1])
                q = np.array([-gx, -gy, 1.0]) / math.sqrt(gx * gx + gy * gy + 1.0)
                d = (c[0] - s[0]) * q[0] + (c[1] - s[1]) * q[1] + (c[2] - z) * q[2]
                t = np.array([c[0] - d * q[0], c[1] - d * q[1]])
                s = np.minimum(np.maximum(t, lo_), hi_)
                face = bool(np.all(s == t))
            z, gx, gy = walls._patch.py_func(x0, y0, hx, hy, bed, ix, iy, s[0], s[1])
            q = np.array([-gx, -gy, 1.0]) / math.sqrt(gx * gx + gy * gy + 1.0)
            e = np.array([c[0] - s[0], c[1] - s[1], c[2] - z])
            d = e[0] * q[0] + e[1] * q[1] + e[2] * q[2]
            if not face and above:
                le = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
                if le > 0.0:
                    q, d = e / le, le
            ov = r - d
            if ov <= 0.0 and ov + reach_t * abs(v[0] * q[0] + v[1] * q[1] + v[2] * q[2]) <= 0.0:
                continue
            found.append((q, ov, face))
    taken = []
    deepest_face = -math.inf
    for want_face in (True, False):
        for q, ov, face in sorted([f for f in found if f[2] is want_face], key=lambda f: -f[1]):
            if not want_face and (ov <= deepest_face or sum(not t[2] for t in taken) == 1):
                continue
            if any(q[0] * t[0][0] + q[1] * t[0][1] + q[2] * t[0][2] > walls.SAME_CONTACT_COS for t in taken):
                continue
            if len(taken) < walls.MAX_TERRAIN_CONTACTS:
                taken.append((q, ov, face))
                if face:
                    deepest_face = max(deepest_face, ov)
    if taken:
        top = max(range(len(taken)), key=lambda k: (taken[k][0][2], -k))
        taken[0], taken[top] = taken[top], taken[0]
    return [(q, ov) for q, ov, _ in taken]


def reference_heightfield(idx, x0, y0, hx, hy, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia,
                          props, dt, force, torque, lo, hi, vel_h, omega_h, law):
    reach_t = max(-lo, hi) if law == STEP_AVERAGED else 0.0
    nc = 0
    for i in map(int, idx):
        contacts = reference_terrain_contacts(x0, y0, hx, hy, bed, pos[i], radius[i], vel[i], reach_t)
        if not contacts:
            hist[i] = 0.0
            rhist[i] = 0.0
            continue
        for k, (q, overlap) in enumerate(contacts):
            nc += overlap > 0.0
            if k == 0:  # the first keeps the histories
                _contact(i, -q, overlap, np.zeros(3), hist, rhist, vel, omega, vel_h, omega_h, radius, mass, inertia,
                         props[i], wprops, dt, lo, hi, law, force, torque)
            else:  # a further contact: no history, no rolling resistance
                h, rh = hist.copy(), rhist.copy()
                h[i] = 0.0
                wp = wprops.copy()
                wp[7] = 0.0
                _contact(i, -q, overlap, np.zeros(3), h, rh, vel, omega, vel_h, omega_h, radius, mass, inertia,
                         props[i], wp, dt, lo, hi, law, force, torque)
    return nc


def particles(seed, gap_of, n=160):
    """n spheres with gaps to the boundary (gap_of(rng, n) -> signed gaps, the centre placed by the caller),
    velocities, spins, histories (some zero, some -0.0), mixed property rows."""
    rng = np.random.default_rng(seed)
    radius = rng.uniform(0.2, 0.3, n)
    mass = 2650.0 * 4.0 / 3.0 * np.pi * radius**3
    inertia = 0.4 * mass * radius**2
    kind = np.arange(n) % 4
    # overlapping (0 - 5 mm); within the interval reach of a fast normal speed (|gap| < 2 mm, +-4 m/s); far
    gap = np.where(kind == 0, -rng.uniform(0, 5e-3, n), np.where(kind == 3, rng.uniform(0.05, 0.2, n),
                                                                 rng.uniform(-2e-3, 2e-3, n)))
    vn = np.where(kind == 1, -4.0, np.where(kind == 2, 4.0, 0.5)) * rng.uniform(0.2, 1.0, n)  # + away
    hist = rng.normal(0, 1e-4, (n, 3)) * (rng.random((n, 1)) < 0.6)
    rhist = rng.normal(0, 50.0, (n, 3)) * (rng.random((n, 1)) < 0.5)
    hist[::7, 1] = -0.0
    rhist[::9, 0] = -0.0
    props = np.tile(BASE, (n, 1))
    props[1::3, 2] *= 1.7  # stiffer
    props[2::5, 5] *= 0.3
    props[::4, 1] = 0.3
    props[::6, 0] = -0.0  # signed zero adhesion
    props[3::7, 0] = 50.0  # adhesion
    props[::2, 7] = 0.0  # no rolling friction on half the rows
    return dict(radius=radius, mass=mass, inertia=inertia, gap=gap, vn=vn, hist=hist, rhist=rhist, props=props,
                vt=rng.normal(0, 0.3, (n, 3)), omega=rng.normal(0, 2.0, (n, 3)), dv=rng.normal(0, 0.05, (n, 3)),
                dw=rng.normal(0, 0.5, (n, 3)), idx=rng.permutation(n)[: n - 10], rng=rng)


def _wall_props():
    wp = BASE.copy()
    wp[0] = 0.0
    wp[2] = 1.2e7
    return wp


def plane_case(seed, moving):
    c = particles(seed, None)
    normal = np.array([0.1, -0.2, 1.0])
    normal /= np.linalg.norm(normal)
    point = np.array([0.3, -0.2, 0.1])
    n = c["radius"].size
    rng = c["rng"]
    t = rng.uniform(-3, 3, (n, 3))
    t -= (t @ normal)[:, None] * normal  # tangential offsets
    pos = point + t + (c["radius"] + c["gap"])[:, None] * normal
    wvel = np.array([0.2, -0.1, 0.05]) if moving else np.zeros(3)
    vel = c["vt"] - ((c["vt"] @ normal) - c["vn"])[:, None] * normal + wvel  # normal speed vn relative to the plane
    return c, pos, vel, point, normal, wvel


def _plane_args(c, pos, vel, point, normal, wvel, law, split):
    lo, hi = (-0.5 * DT, 0.5 * DT) if law == STEP_AVERAGED else (0.0, 0.0)
    vel_h, omega_h = (vel + c["dv"], c["omega"] + c["dw"]) if split else (vel, c["omega"])
    return dict(idx=c["idx"], point=point, normal=normal, wvel=wvel, wprops=_wall_props(), hist=c["hist"].copy(),
                rhist=c["rhist"].copy(), pos=pos, vel=vel, omega=c["omega"], radius=c["radius"], mass=c["mass"],
                inertia=c["inertia"], props=c["props"], dt=DT, force=np.full((pos.shape[0], 3), 0.25),
                torque=np.full((pos.shape[0], 3), -0.5), reaction=np.array([1.0, -2.0, 3.0]), lo=lo, hi=hi,
                vel_h=vel_h, omega_h=omega_h, law=law)


OUT = ("force", "torque", "hist", "rhist")


def _same(got, ref, keys):
    for k in keys:
        assert np.array_equal(got[k].view(np.int64), ref[k].view(np.int64)), k  # every bit, signed zeros too


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("law, split", [(STEP_AVERAGED, True), (STEP_AVERAGED, False), (HOOKE_HISTORY, False),
                                        (HOOKE_HISTORY, True)])
@pytest.mark.parametrize("moving", [False, True])
def test_plane_loop_matches_the_python_reference_bit_for_bit(seed, law, split, moving):
    c, pos, vel, point, normal, wvel = plane_case(seed, moving)
    got = _plane_args(c, pos, vel, point, normal, wvel, law, split)
    ref = _plane_args(c, pos, vel, point, normal, wvel, law, split)
    nc = walls.plane_forces(*got.values())
    assert nc == reference_plane(*ref.values()) > 20
    _same(got, ref, OUT + ("reaction",))
    # the case covers what it is meant to: forces on some, rolling moments kept and cleared, intervals cut
    touched = np.any(ref["force"] != 0.25, axis=1)
    assert 0 < touched.sum() < c["idx"].size
    assert np.any(ref["rhist"][c["idx"]] != 0.0) and np.any(c["rhist"][c["idx"]] != ref["rhist"][c["idx"]])
    if law == STEP_AVERAGED:  # contacts inside the interval only: a force without an overlap now
        ov = c["radius"] - (pos - point) @ normal
        assert np.any(touched & (ov <= 0.0))


def heightfield_case(seed):
    rng = np.random.default_rng(100 + seed)
    x = np.arange(0.0, 8.01, 0.5)
    y = np.arange(-2.0, 4.01, 0.5)
    X, Y = np.meshgrid(x, y)
    bed = 0.15 * X - 0.1 * Y + 0.2 * np.sin(X) * np.cos(0.7 * Y) + rng.normal(0, 0.02, X.shape)
    c = particles(seed, None)
    n = c["radius"].size
    px = rng.uniform(x[0] - 0.5, x[-1] + 0.5, n)  # some outside the grid
    py = rng.uniform(y[0] - 0.3, y[-1] + 0.3, n)
    # centres above the bilinear surface by r + gap along z (the loop measures to the local tangent plane,
    # so the gap it sees differs a little: near-grazing cases on both sides)
    z = np.array([walls._bilinear.py_func(x[0], y[0], 0.5, 0.5, bed, min(max(a, x[0]), x[-1]),
                                          min(max(b, y[0]), y[-1]))[0] for a, b in zip(px, py)])
    pos = np.column_stack([px, py, z + c["radius"] + c["gap"]])
    vel = c["vt"].copy()
    vel[:, 2] = c["vn"]
    return c, pos, vel, bed, (x[0], y[0], 0.5, 0.5)


def heightfield_wall_case(seed):
    """A wall 0.8 m high over one 0.5 m cell (58 degrees) along y = 1.5 and a valley across it, particles
    near the wall's foot, on its face and by its crest: floor-and-wall and ridge contacts."""
    rng = np.random.default_rng(200 + seed)
    x = np.arange(0.0, 8.01, 0.5)
    y = np.arange(-2.0, 4.01, 0.5)
    X, Y = np.meshgrid(x, y)
    bed = np.where(Y < 1.5, 0.0, 0.8) + 0.3 * np.abs(X - 4.0) + rng.normal(0, 0.01, X.shape)
    c = particles(seed, None)
    n = c["radius"].size
    px = rng.uniform(2.5, 5.5, n)
    py = rng.uniform(0.5, 2.5, n)
    z = np.array([walls._bilinear.py_func(x[0], y[0], 0.5, 0.5, bed, a, b)[0] for a, b in zip(px, py)])
    pos = np.column_stack([px, py, z + c["radius"] + c["gap"]])
    vel = c["vt"].copy()
    vel[:, 2] = c["vn"]
    return c, pos, vel, bed, (x[0], y[0], 0.5, 0.5)


@pytest.mark.parametrize("case", [heightfield_case, heightfield_wall_case])
@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("law, split", [(STEP_AVERAGED, True), (STEP_AVERAGED, False), (HOOKE_HISTORY, True)])
def test_heightfield_loop_matches_the_python_reference_bit_for_bit(seed, law, split, case):
    c, pos, vel, bed, (x0, y0, hx, hy) = case(seed)
    lo, hi = (-0.5 * DT, 0.5 * DT) if law == STEP_AVERAGED else (0.0, 0.0)
    vel_h, omega_h = (vel + c["dv"], c["omega"] + c["dw"]) if split else (vel, c["omega"])

    def args():
        return dict(idx=c["idx"], x0=x0, y0=y0, hx=hx, hy=hy, bed=bed, wprops=_wall_props(), hist=c["hist"].copy(),
                    rhist=c["rhist"].copy(), pos=pos, vel=vel, omega=c["omega"], radius=c["radius"], mass=c["mass"],
                    inertia=c["inertia"], props=c["props"], dt=DT, force=np.full((pos.shape[0], 3), 0.25),
                    torque=np.full((pos.shape[0], 3), -0.5), lo=lo, hi=hi, vel_h=vel_h, omega_h=omega_h, law=law)

    got, ref = args(), args()
    nc = walls.heightfield_forces(*got.values())
    assert nc == reference_heightfield(*ref.values()) > 10
    _same(got, ref, OUT)
    touched = np.any(ref["force"] != 0.25, axis=1)
    outside = (pos[:, 0] < x0) | (pos[:, 0] > x0 + (bed.shape[1] - 1) * hx)
    assert 0 < touched.sum() and not np.any(touched & outside)
    assert np.all(ref["hist"][c["idx"][outside[c["idx"]]]] == 0.0)  # cleared outside the grid
    if case is heightfield_wall_case:  # the case holds particles with two and three contacts
        counts = [len(reference_terrain_contacts(x0, y0, hx, hy, bed, pos[i], c["radius"][i], vel[i], max(-lo, hi)))
                  for i in c["idx"]]
        assert max(counts) >= 2 and sum(k >= 2 for k in counts) >= 5
