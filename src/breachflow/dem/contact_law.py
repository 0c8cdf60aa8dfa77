"""The linear spring–dashpot contact law with friction history and rolling resistance (docs/theory.md, *DEM contact*).

Contact law (docs/theory.md, *DEM contact*), ``n`` from particle i to its partner, overlap ``u_N > 0``:

* normal ``f_N = -k_N u_N n + c_CN (v_rel . n) n`` on i;
* tangential spring on the accumulated displacement ``u_S`` (kept per pair across steps and
  rotated into the current tangent plane with its length kept), ``f_S = k_S u_S``;
  slip limit ``u_S_hat = (alpha + beta k_N u_N) / k_S``; beyond it ``u_S`` is cut back to
  ``u_S_hat`` (plastic slip); dashpot ``c_CS v_S`` while sticking, ``c_CF v_S`` while slipping;
* torque ``(r n) x f_S`` on each partner (lever arm D/2);
* rolling resistance (extension, ``rolling_friction`` mu_r > 0): :func:`rolling_law`.

Properties of a contact are the minimum of the partners' values.

Integrators apply a force over a interval around its evaluation time; :func:`contact_law` averages the
law over that interval (issue 12), so contact onset and release inside a step are resolved.

The law is chosen by name from the registry ``breachflow.contact_laws`` (:data:`contact_laws`,
``DemSimulation(contact_law=...)``); both built-ins are this spring–dashpot, computed differently:

* ``"step_averaged"`` (default, :class:`StepAveraged`; ``"window_averaged"`` is its former name, kept as an
  alias) — :func:`contact_law`: the law averaged over the interval of the step the integrator applies it over, the shear history turned into the tangent plane with its length kept, the
  Coulomb limit on the spring;
* ``"hooke_history"`` (:class:`HookeHistory`) — :func:`hooke_history`: LAMMPS ``pair_style
  gran/hooke/history`` exactly (point values at the evaluation time, history projected into the tangent
  plane, Coulomb limit on the spring + dashpot force), for like-for-like comparisons with LAMMPS
  (``benchmarks/bench_dem.py``). Less accurate where a contact begins or ends inside a step: at the default
  step its coefficient of restitution depends on the onset phase (tests/dem/test_contact_laws.py gives the
  measured spread).

The compiled contact kernels hold both laws and select one by the class attribute ``code`` (a plug-in
registered here cannot add a third without a kernel for it). Rolling resistance (:func:`rolling_law`) and
the boundaries use the chosen law too.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..registry import Registry

#: kernel codes
STEP_AVERAGED, HOOKE_HISTORY = 0, 1
#: rolling stiffness ``k_r = ROLLING_STIFFNESS * k_N mu_r^2 R_r^2`` (Ai et al. 2011, 3-D value)
ROLLING_STIFFNESS = 2.25
#: rolling dashpot ``C_r = ROLLING_DAMPING_RATIO * 2 sqrt(I_r k_r)`` (Ai et al. 2011 eta_r)
ROLLING_DAMPING_RATIO = 0.3
#: :func:`history_in_plane` uses its series below this ``x``
TURN_SERIES = 2.0**-14


@numba.njit(cache=True, inline="always", error_model="numpy")
def averaging_interval(u, w, lo, hi):
    """Active part of the force interval ``[lo, hi]`` (s, relative to the evaluation time) for the overlap
    ``u(tau) = u + w tau``: returns (fraction phi of the interval in contact, midpoint m of the active part).

    ``hi <= lo`` (a point evaluation, e.g.
    :meth:`~breachflow.dem.simulation.DemSimulation.refresh_forces`): (1, 0) if u > 0 else (0, 0).
    """
    if hi <= lo:
        return (1.0, 0.0) if u > 0.0 else (0.0, 0.0)
    a = lo
    b = hi
    if w > 0.0:
        a = max(a, -u / w)
    elif w < 0.0:
        b = min(b, -u / w)
    elif u <= 0.0:
        return 0.0, 0.0
    if b <= a:
        return 0.0, 0.0
    return (b - a) / (hi - lo), 0.5 * (a + b)


@numba.njit(cache=True, inline="always", error_model="numpy")
def history_in_plane(hist, p, nx, ny, nz):
    """Row *p* of a contact history (shear or rolling) rotated into the plane normal to ``n``, its
    length kept (the contact plane turns as the partners move); also returns its squared length.

    ``h`` loses its normal part ``h_n = h . n`` and is scaled by ``|h| / |h_t| = (1 - x)^-1/2``,
    ``x = h_n^2 / |h|^2`` (the plane turned by about ``sqrt(x)`` rad since the history was stored). For
    ``x < 2^-14`` (less than 0.45 degrees: all but the fastest-turning contacts) the series
    ``1 + x/2 + 3x^2/8 + 5x^3/16`` is used (remainder ``< 35 x^4 / 128 < 4e-18``, below one rounding), with
    ``1 / |h|^2`` computed from the stored history alone, beside the normal's square root and division
    instead of after them: on the 1000-sphere settled bed the step-averaged pair loop is about 7 % faster
    than with ``sqrt(|h|^2) / sqrt(|h_t|^2)`` (latency, not the count of roots and divisions, bounds it;
    ``python3 tasks.py bench dem_kernel --old <src>``). Otherwise, and for a zero history, the quotient of
    the two square roots.
    """
    h0x = hist[p, 0]
    h0y = hist[p, 1]
    h0z = hist[p, 2]
    s0 = h0x * h0x + h0y * h0y + h0z * h0z
    r0 = 1.0 / s0  # off the critical path: depends on the stored history only, not on n
    hn = h0x * nx + h0y * ny + h0z * nz
    hx = h0x - hn * nx
    hy = h0y - hn * ny
    hz = h0z - hn * nz
    x = hn * hn * r0
    if x < TURN_SERIES:
        sc = 1.0 + x * (0.5 + x * (0.375 + x * 0.3125))
        hx *= sc
        hy *= sc
        hz *= sc
    else:
        h1 = math.sqrt(hx * hx + hy * hy + hz * hz)
        if h1 > 0.0:
            sc = math.sqrt(s0) / h1
            hx *= sc
            hy *= sc
            hz *= sc
    return hx, hy, hz, s0


@numba.njit(cache=True, inline="always", error_model="numpy")
def contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, p, kn, ks, c_cn, c_cs, c_cf, alpha, beta, dt, lo,
                hi):
    """Force on particle i from one contact (docs/theory.md, *DEM contact*), averaged over the integrator's force interval;
    updates the shear history *hist* in place. Returns the interval fraction in contact (0: none).

    (nx, ny, nz): unit normal from i to the partner; (vx, vy, vz): velocity of the partner's contact
    point relative to i's at the evaluation time (dashpots, interval); (gx, gy, gz): the same over the last
    step, i.e. with the velocities that moved the positions (the half-step ones of Verlet), which advances
    the shear displacement consistently with the overlap; *overlap* ``u`` at the evaluation time (may be
    <= 0); the pair's history is row *p* of *hist* (``u_S`` at the previous evaluation, ``dt`` earlier). Writes
    (fx, fy, fz, ftx, fty, ftz, compressive normal force) into *out*.

    Interval (issue 12): a kick–drift–kick integrator applies the force evaluated at ``t`` over
    ``[t - dt/2, t + dt/2]`` (``lo = -dt/2, hi = dt/2``). The contact law is piecewise — the dashpot
    jumps from 0 to ``c_CN v_N`` at onset and back at release, springs have a kink — so a point value
    makes the impulse depend on where in a step the contact begins (restitution errors up to ~10 % at the
    default step). Here the overlap is taken linear across the interval, ``u(tau) = u + w tau`` with the
    closing speed ``w = -v_rel . n``, and the law is averaged over it: with phi the fraction of the
    interval in contact and m the midpoint of the in-contact part, ``F = phi [(-k_N u(m) + c_CN v_N) n +
    k_S u_S(m) + c_t v_S]``, ``u_S(m) = u_S(t) + v_S m`` (capped at the Coulomb limit of ``u(m)``; a
    contact sliding now and in contact only before now keeps ``u_S`` at that limit instead).
    When the whole interval is in contact (phi = 1, m = 0) this is the usual point value, bit for bit.
    The shear history counts from the touching time: a fresh contact (zero history, approaching) gets
    ``u_S = g_S min(dt, u/g_N)`` instead of ``g_S dt``.
    """
    vn = vx * nx + vy * ny + vz * nz
    w = -vn
    full = overlap > max(-lo, hi) * abs(vn)  # in contact over the whole interval (the common case)
    if full:
        phi, m = 1.0, 0.0
    else:
        phi, m = averaging_interval(overlap, w, lo, hi)
    if phi <= 0.0:
        hist[p, 0] = 0.0
        hist[p, 1] = 0.0
        hist[p, 2] = 0.0
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    tx = vx - vn * nx
    ty = vy - vn * ny
    tz = vz - vn * nz
    # rotate the history into the current tangent plane, keeping its length
    hx, hy, hz, h0sq = history_in_plane(hist, p, nx, ny, nz)
    slipping = False
    gn = gx * nx + gy * ny + gz * nz
    if overlap > 0.0:  # in contact at the evaluation time: advance the stored history
        d = dt
        if h0sq == 0.0 and gn < 0.0 and overlap < -gn * dt:  # fresh contact: it began overlap/g_N ago
            d = -overlap / gn
        hx += (gx - gn * nx) * d
        hy += (gy - gn * ny) * d
        hz += (gz - gn * nz) * d
        us = math.sqrt(hx * hx + hy * hy + hz * hz)
        us_hat = (alpha + beta * kn * overlap) / ks
        if us >= us_hat:  # plastic slip: the spring is cut back to the Coulomb limit
            slipping = True
            if us > 0.0:
                sc = us_hat / us
                hx *= sc
                hy *= sc
                hz *= sc
        hist[p, 0] = hx
        hist[p, 1] = hy
        hist[p, 2] = hz
        if full:  # the point value
            c_t = c_cf if slipping else c_cs
            fnm = -kn * overlap + c_cn * vn
            ftx = ks * hx + c_t * tx
            fty = ks * hy + c_t * ty
            ftz = ks * hz + c_t * tz
            return 1.0, fnm * nx + ftx, fnm * ny + fty, fnm * nz + ftz, ftx, fty, ftz, -fnm
        if slipping and m < 0.0 and us_hat > 0.0:  # sliding before now: the spring sat at the Coulomb limit
            sc = (alpha + beta * kn * (overlap + w * m)) / ks / us_hat
            sx = hx * sc
            sy = hy * sc
            sz = hz * sc
        else:  # sticking: the spring's elastic path
            sx = hx + tx * m
            sy = hy + ty * m
            sz = hz + tz * m
    else:  # in contact only during part of the interval: not at the evaluation time
        hist[p, 0] = 0.0
        hist[p, 1] = 0.0
        hist[p, 2] = 0.0
        if w > 0.0:  # onset ahead, at a = 2m - hi: u_S(m) = v_S (m - a)
            d = hi - m
            sx = tx * d
            sy = ty * d
            sz = tz * d
        else:  # release behind, the last history dt ago: u_S(m) = u_S(-dt) + g_S (m + dt)
            d = m + dt
            sx = hx + (gx - gn * nx) * d
            sy = hy + (gy - gn * ny) * d
            sz = hz + (gz - gn * nz) * d
    um = overlap + w * m  # overlap at the midpoint of the in-contact part
    if m != 0.0:  # part of the interval only: the Coulomb limit of the mid-interval overlap
        us = math.sqrt(sx * sx + sy * sy + sz * sz)
        us_hat = (alpha + beta * kn * um) / ks
        if us >= us_hat:
            slipping = True
            if us > 0.0:
                sc = us_hat / us
                sx *= sc
                sy *= sc
                sz *= sc
    c_t = c_cf if slipping else c_cs  # friction dashpot while slipping, shear dashpot while sticking
    fnm = phi * (-kn * um + c_cn * vn)
    ftx = phi * (ks * sx + c_t * tx)
    fty = phi * (ks * sy + c_t * ty)
    ftz = phi * (ks * sz + c_t * tz)
    return phi, fnm * nx + ftx, fnm * ny + fty, fnm * nz + ftz, ftx, fty, ftz, -fnm  # compressive normal force magnitude (N)


@numba.njit(cache=True, inline="always", error_model="numpy")
def hooke_history(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, p, kn, ks, c_cn, c_cs, alpha, beta, dt):
    """LAMMPS ``pair_style gran/hooke/history`` (and ``fix wall/gran hooke/history``), evaluated at the
    point ``t`` (no force interval): the law of :func:`contact_law` as LAMMPS computes it, for like-for-like
    comparisons (``contact_law = "hooke_history"``, :data:`contact_laws`). Arguments as :func:`contact_law`;
    *overlap* must be > 0 (the caller skips pairs not in contact now). Returns 1.

    Differences from the default law (LAMMPS' ``compute``, Silbert et al. 2001): the shear displacement
    ``u_S += g_S dt`` is advanced before it is turned into the tangent plane, and turned by projection
    (``u_S - (u_S . n) n``: it shrinks as the contact rolls); the Coulomb limit applies to the whole
    tangential force ``|k_S u_S + c_CS v_S| <= alpha + mu |f_N|`` (f_N with its dashpot), and on slip the
    spring is set to ``u_S = (F/|f_t|)(u_S + c_CS v_S / k_S) - c_CS v_S / k_S``; one tangential dashpot
    ``c_CS`` (``c_CF`` is unused); onset and release are resolved to a step, not within it.
    ``alpha`` = 0 is LAMMPS exactly (LAMMPS has no adhesion term).
    """
    vn = vx * nx + vy * ny + vz * nz
    tx = vx - vn * nx
    ty = vy - vn * ny
    tz = vz - vn * nz
    gn = gx * nx + gy * ny + gz * nz
    hx = hist[p, 0] + (gx - gn * nx) * dt
    hy = hist[p, 1] + (gy - gn * ny) * dt
    hz = hist[p, 2] + (gz - gn * nz) * dt
    shrmag_sq = hx * hx + hy * hy + hz * hz
    hn = hx * nx + hy * ny + hz * nz
    hx -= hn * nx
    hy -= hn * ny
    hz -= hn * nz
    fnm = -kn * overlap + c_cn * vn
    ftx = ks * hx + c_cs * tx
    fty = ks * hy + c_cs * ty
    ftz = ks * hz + c_cs * tz
    fs_sq = ftx * ftx + fty * fty + ftz * ftz
    f_hat = alpha + beta * abs(fnm)
    if fs_sq > f_hat * f_hat:
        if shrmag_sq != 0.0:
            sc = f_hat / math.sqrt(fs_sq)
            ct = c_cs / ks
            hx = sc * (hx + ct * tx) - ct * tx
            hy = sc * (hy + ct * ty) - ct * ty
            hz = sc * (hz + ct * tz) - ct * tz
            ftx *= sc
            fty *= sc
            ftz *= sc
        else:
            ftx = 0.0
            fty = 0.0
            ftz = 0.0
    hist[p, 0] = hx
    hist[p, 1] = hy
    hist[p, 2] = hz
    return 1.0, fnm * nx + ftx, fnm * ny + fty, fnm * nz + ftz, ftx, fty, ftz, -fnm


@numba.njit(cache=True, inline="always", error_model="numpy")
def rolling_law(nx, ny, nz, wx, wy, wz, fn, r_eff, mu_r, kn, i_eff, rhist, p, dt, out):
    """Rolling resistance moment on particle i: elastic–plastic spring–dashpot ("type C", model EPSD of
    Ai, Chen, Rotter & Ooi 2011, Powder Technol. 206:269). Updates the moment history ``rhist[p]``.

    (wx, wy, wz) = ``w_i - w_j`` (partner's spin, 0 for a wall); only its tangential part rolls.
    Spring ``M_k <- M_k - k_r w_t dt`` (history rotated into the current tangent plane, length kept),
    ``k_r = 2.25 k_N mu_r^2 R_r^2``; capped at full mobilisation ``|M_k| <= M_m = mu_r R_r F_N``;
    dashpot ``-C_r w_t``, ``C_r = 0.3 * 2 sqrt(I_r k_r)``, only below full mobilisation (Ai's f = 0),
    ``I_r`` the inertia about the contact point (``(1/I_ri + 1/I_rj)^-1``, ``I_ri = I_i + m_i r_i^2``).
    Unlike Ai et al., the total ``|M_k + M_d|`` is also capped at ``M_m``: otherwise the dashpot alone
    exceeds the limit while the spring winds up at a newly formed rolling contact, and a rolling sphere
    loses extra speed each time a contact forms. The partner gets ``-M``. Writes the moment into out[0:3].

    Why type C and not the constant directional torque (type A, ``-mu_r R_r F_N w/|w|``): type A flips
    sign every step around ``w = 0`` and cannot hold a sphere at rest on a slope or under a side load
    (it chatters); the spring gives a true static moment up to ``M_m`` (rest iff the load needs less),
    and while rolling (fully mobilised) it is exactly type A's constant ``M_m`` — so a rolling sphere on
    a plane decelerates at ``a = -(5/7) mu_r g`` and one on an incline accelerates at
    ``(5/7) g (sin t - mu_r cos t)``. Plastic capping only removes spring energy: no energy gain.
    """
    wn = wx * nx + wy * ny + wz * nz
    tx = wx - wn * nx
    ty = wy - wn * ny
    tz = wz - wn * nz
    hx, hy, hz, _ = history_in_plane(rhist, p, nx, ny, nz)
    kr = ROLLING_STIFFNESS * kn * mu_r * mu_r * r_eff * r_eff
    hx -= kr * tx * dt
    hy -= kr * ty * dt
    hz -= kr * tz * dt
    m_max = mu_r * r_eff * max(fn, 0.0)
    mk = math.sqrt(hx * hx + hy * hy + hz * hz)
    if mk >= m_max:  # full mobilisation: plastic rolling at the limit moment, no dashpot
        sc = m_max / mk if mk > 0.0 else 0.0
        hx *= sc
        hy *= sc
        hz *= sc
        cr = 0.0
    else:
        cr = ROLLING_DAMPING_RATIO * 2.0 * math.sqrt(i_eff * kr)
    rhist[p, 0] = hx
    rhist[p, 1] = hy
    rhist[p, 2] = hz
    mx = hx - cr * tx
    my = hy - cr * ty
    mz = hz - cr * tz
    mt = math.sqrt(mx * mx + my * my + mz * mz)
    if mt > m_max:  # the dashpot may not lift the moment above the limit (e.g. while the spring winds up)
        sc = m_max / mt
        mx *= sc
        my *= sc
        mz *= sc
    out[0] = mx
    out[1] = my
    out[2] = mz


# --------------------------------------------------------------------------------------------------
# the choice of law

#: the contact laws, by name (entry-point group ``breachflow.contact_laws``)
contact_laws: Registry = Registry("DEM contact law", "breachflow.contact_laws", default="step_averaged")


def _props(kn, ks, c_cn, c_cs, c_cf, alpha, beta):
    return float(kn), float(ks), float(c_cn), float(c_cs), float(c_cf), float(alpha), float(beta)


@contact_laws.register("window_averaged")  # the former name, kept as an alias
@contact_laws.register("step_averaged")
class StepAveraged:
    """The default law, averaged over the interval ``[lo, hi]`` of the step the force is applied over
    (:func:`contact_law`)."""

    code = STEP_AVERAGED

    def force(self, n, overlap, v, g, hist, kn, ks, c_cn, c_cs, c_cf, alpha, beta, dt, lo=0.0, hi=0.0):
        """Force (on the particle n points away from) of one contact with history *hist* (3,), updated in
        place; returns (interval fraction in contact, force (3,), tangential force (3,), compressive ``|f_N|``)."""
        h = np.asarray(hist, float).reshape(1, 3)
        kn, ks, c_cn, c_cs, c_cf, alpha, beta = _props(kn, ks, c_cn, c_cs, c_cf, alpha, beta)
        r = contact_law(*map(float, n), float(overlap), *map(float, v), *map(float, g), h, 0, kn, ks, c_cn, c_cs,
                        c_cf, alpha, beta, float(dt), float(lo), float(hi))
        hist[:] = h[0]
        return r[0], np.array(r[1:4]), np.array(r[4:7]), r[7]


@contact_laws.register("hooke_history")
class HookeHistory(StepAveraged):
    """LAMMPS ``gran/hooke/history`` at points (:func:`hooke_history`; ``c_cf`` unused)."""

    code = HOOKE_HISTORY

    def force(self, n, overlap, v, g, hist, kn, ks, c_cn, c_cs, c_cf, alpha, beta, dt, lo=0.0, hi=0.0):
        """As :meth:`StepAveraged.force`, at the evaluation time (*lo*, *hi* ignored; *overlap* > 0)."""
        h = np.asarray(hist, float).reshape(1, 3)
        kn, ks, c_cn, c_cs, c_cf, alpha, beta = _props(kn, ks, c_cn, c_cs, c_cf, alpha, beta)
        r = hooke_history(*map(float, n), float(overlap), *map(float, v), *map(float, g), h, 0, kn, ks, c_cn, c_cs,
                          alpha, beta, float(dt))
        hist[:] = h[0]
        return r[0], np.array(r[1:4]), np.array(r[4:7]), r[7]


def resolve(law) -> object:
    """A contact-law instance from a registry name or an instance; InputError for an unknown name or a
    law without a kernel code."""
    from ..errors import InputError

    obj = contact_laws.create(law)
    if getattr(obj, "code", None) not in (STEP_AVERAGED, HOOKE_HISTORY):
        raise InputError(f"contact law {law!r} has no compiled kernel (choose one of: step_averaged, "
                         f"hooke_history)")
    return obj
