"""Erosion of the bed where the flow is fastest: bed shear from the shallow-water flow, Shields' threshold per
cell for the bed's grain size, the bed-load law of Meyer-Peter & Müller (1948) and the Exner equation. Used
as a scour estimate on the steady flow of a cycle (the flow's unit discharge and water level held; the depth
grows as the bed scours, so the scour levels off where the shear falls to the threshold). User
documentation: ``docs/bed-and-forces.md``.

Bed shear (Manning, as the SWE's friction term)
    ``tau = rho g n^2 |u|^2 / h^(1/3)``.
Shields parameter ``theta = tau / ((rho_s - rho) g d)``; threshold ``theta_c = 0.047`` (Meyer-Peter & Müller
    1948, the constant of their law; Shields' curve gives 0.03–0.06 for coarse grains).
Bed load (Meyer-Peter & Müller 1948, in Wong & Parker's 2006 notation)
    ``q_b* = 8 (theta - theta_c)^1.5`` for ``theta > theta_c``, ``q_b = q_b* sqrt(Delta g d^3)`` (m^2/s,
    solid volume) along the flow.
Exner
    ``(1 - p) dz/dt = -div q_b``, finite volumes on the grid: face fluxes upwind in the direction of the face's
    mean transport, closed (no flux) or open (outflow leaves, nothing enters) domain edges: the bed volume of
    a closed domain is conserved to round-off. Explicit sub-steps: each limited so that no cell changes by
    more than ``max_change`` of its depth (default 2 %).

The cell's grain size may vary: a bottom protection is a region of larger grains (``d`` map), which does not
move while its own threshold is not exceeded.

Equilibrium (clear water, no supply from upstream): the bed scours until ``theta = theta_c``, i.e.
``h_eq = (rho g n^2 q^2 / tau_c)^(3/7)`` with the unit discharge ``q = h |u|`` — Laursen's (1963) clear-water
contraction scour, the formula of FHWA HEC-18 (Arneson et al. 2012), with ``n = 0.041 d^(1/6)`` and
``theta_c = 0.039``: :func:`equilibrium_depth`.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..errors import InputError

G = 9.80665
RHO_W = 1000.0
#: Meyer-Peter & Müller's threshold and coefficient
MPM_THETA_C = 0.047
MPM_COEFF = 8.0
MPM_EXPONENT = 1.5


def bed_shear(depth, u, v, manning, rho=RHO_W, g=G, dry=1e-3):
    """``tau = rho g n^2 |u|^2 / h^(1/3)`` (Pa) per cell; 0 on dry cells (depth <= *dry*)."""
    h = np.asarray(depth, float)
    sp2 = np.asarray(u, float) ** 2 + np.asarray(v, float) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = rho * g * np.asarray(manning, float) ** 2 * sp2 / np.cbrt(h)
    return np.where(h > dry, tau, 0.0)


def shields(tau, d, rho_s=2650.0, rho=RHO_W, g=G):
    """Shields' parameter ``tau / ((rho_s - rho) g d)``."""
    return np.asarray(tau, float) / ((rho_s - rho) * g * np.asarray(d, float))


def mpm_transport(theta, d, rho_s=2650.0, rho=RHO_W, g=G, theta_c=MPM_THETA_C):
    """Meyer-Peter–Müller bed load ``8 (theta - theta_c)^1.5 sqrt(Delta g d^3)`` (m^2/s), 0 below the threshold."""
    delta = (rho_s - rho) / rho
    excess = np.maximum(np.asarray(theta, float) - theta_c, 0.0)
    return MPM_COEFF * excess ** MPM_EXPONENT * np.sqrt(delta * g * np.asarray(d, float) ** 3)


def equilibrium_depth(q, d, manning, rho_s=2650.0, rho=RHO_W, g=G, theta_c=MPM_THETA_C):
    """Clear-water equilibrium depth ``(rho g n^2 q^2 / tau_c)^(3/7)`` (m) of a unit discharge *q* (m^2/s) over
    grains *d* (Laursen 1963; module docstring)."""
    tau_c = theta_c * (rho_s - rho) * g * np.asarray(d, float)
    return (rho * g * np.asarray(manning, float) ** 2 * np.asarray(q, float) ** 2 / tau_c) ** (3.0 / 7.0)


@numba.njit(cache=True)
def exner_divergence(qx, qy, dx, dy, open_edges, out):
    """``div q`` (m/s) of the cell-centred bed-load fluxes *qx*, *qy* into *out*: face fluxes upwind in the sign
    of the face's mean flux; domain edges closed, or with *open_edges* outflow leaves and nothing enters."""
    ny, nx = qx.shape
    for j in range(ny):
        for i in range(nx):
            out[j, i] = 0.0
    for j in range(ny):
        for i in range(nx - 1):
            m = 0.5 * (qx[j, i] + qx[j, i + 1])
            f = qx[j, i] if m > 0.0 else qx[j, i + 1]
            if m == 0.0:
                f = 0.0
            out[j, i] += f / dx
            out[j, i + 1] -= f / dx
        if open_edges:
            if qx[j, nx - 1] > 0.0:
                out[j, nx - 1] += qx[j, nx - 1] / dx
            if qx[j, 0] < 0.0:
                out[j, 0] -= qx[j, 0] / dx
    for i in range(nx):
        for j in range(ny - 1):
            m = 0.5 * (qy[j, i] + qy[j + 1, i])
            f = qy[j, i] if m > 0.0 else qy[j + 1, i]
            if m == 0.0:
                f = 0.0
            out[j, i] += f / dy
            out[j + 1, i] -= f / dy
        if open_edges:
            if qy[ny - 1, i] > 0.0:
                out[ny - 1, i] += qy[ny - 1, i] / dy
            if qy[0, i] < 0.0:
                out[0, i] -= qy[0, i] / dy


def scour(bed, depth, u, v, d, manning, duration, *, dx, dy, porosity=0.4, rho_s=2650.0, rho=RHO_W, g=G,
          theta_c=MPM_THETA_C, open_edges=True, max_change=0.02, dry=1e-3, max_steps=200000, d_deposit=None):
    """Evolve the bed by Meyer-Peter–Müller and Exner for *duration* (s) under a steady flow whose water level
    and unit discharge ``(h u, h v)`` per cell are held (the velocity falls as the bed scours). *d*: grain size
    (m, scalar or map: a protection is larger grains); what deposits above a cell's initial level is of grain
    size *d_deposit* (default the smallest of *d*: the mobile bed material), so it moves on over a protection.
    Returns ``(new_bed, steps, t)``: the scour depth is ``max(bed - new_bed, 0)`` after the flow time *t* (s),
    *duration* unless *max_steps* explicit steps ended it earlier (fast flow over fine sand needs many)."""
    z = np.array(bed, float)
    h0 = np.asarray(depth, float)
    if z.shape != h0.shape or np.shape(u) != z.shape or np.shape(v) != z.shape:
        raise InputError(f"scour: bed {z.shape}, depth {h0.shape}, u {np.shape(u)}, v {np.shape(v)} differ in shape")
    if not (duration >= 0 and 0 <= porosity < 1 and dx > 0 and dy > 0):
        raise InputError(f"scour: need duration >= 0, 0 <= porosity < 1, dx, dy > 0 (got {duration!r}, "
                         f"{porosity!r}, {dx!r}, {dy!r})")
    wet = h0 > dry
    level = z + h0
    qx = np.where(wet, h0 * np.asarray(u, float), 0.0)
    qy = np.where(wet, h0 * np.asarray(v, float), 0.0)
    dmap = np.broadcast_to(np.asarray(d, float), z.shape)
    n = np.broadcast_to(np.asarray(manning, float), z.shape)
    d_dep = float(dmap.min()) if d_deposit is None else float(d_deposit)
    z0 = z.copy()
    div = np.empty_like(z)
    t, steps = 0.0, 0
    while t < duration and steps < max_steps:
        h = np.where(wet, level - z, 0.0)
        hs = np.where(wet & (h > dry), h, np.inf)
        ux, uy = qx / hs, qy / hs
        sp = np.hypot(ux, uy)
        dc = np.where(z > z0, d_dep, dmap)  # a deposit is of the mobile material
        tau = bed_shear(h, ux, uy, n, rho, g, dry)
        qb = mpm_transport(shields(tau, dc, rho_s, rho, g), dc, rho_s, rho, g, theta_c)
        # a deposit over a base that holds (a protection): it carries at most what lies on the base, the
        # transport falling with the deposit's thickness over one grain of it (a non-erodible layer), so the
        # base is never eroded through the deposit
        hard = (dmap > d_dep) & (shields(tau, dmap, rho_s, rho, g) <= theta_c)
        thin = np.clip((z - z0) / d_dep, 0.0, 1.0)
        qb = np.where(hard, qb * thin, qb)
        with np.errstate(invalid="ignore", divide="ignore"):
            bx = np.where(sp > 0, qb * ux / sp, 0.0)
            by = np.where(sp > 0, qb * uy / sp, 0.0)
        exner_divergence(bx, by, float(dx), float(dy), bool(open_edges), div)
        rate = div / (1.0 - porosity)  # -dz/dt
        act = wet & (rate != 0.0)
        if not act.any():
            break
        # explicit step: no wet cell's bed changes by more than max_change of its depth
        dt = min(duration - t, max_change * float(np.min(np.maximum(h[act], dry) / np.abs(rate[act]))))
        # and a deposit on a holding base loses less than itself per step: its outflow, at most sqrt(2) q_b
        # through the cell's faces, empties it in d (1 - p) min(dx, dy) (z - z0) / (sqrt(2) q_b d) s
        lay = hard & (qb > 0.0)
        if lay.any():
            dt = min(dt, 0.5 * float(np.min(d_dep * (1.0 - porosity) * min(dx, dy) * thin[lay] / qb[lay])))
        z -= rate * dt
        t += dt
        steps += 1
    return z, steps, t


def equilibrium_scour(depth, u, v, d, manning, rho_s=2650.0, rho=RHO_W, g=G, theta_c=MPM_THETA_C, dry=1e-3):
    """Clear-water equilibrium scour depth per cell, ``max(h_eq - h, 0)`` (m), ``h_eq`` of :func:`equilibrium_depth`
    with the cell's unit discharge ``q = h |u|``: how deep the bed scours under the flow held steady with no
    sediment fed from upstream (Laursen 1963; HEC-18) — an upper estimate of :func:`scour` run to the end."""
    h = np.asarray(depth, float)
    q = h * np.hypot(np.asarray(u, float), np.asarray(v, float))
    heq = equilibrium_depth(q, d, manning, rho_s, rho, g, theta_c)
    return np.where(h > dry, np.maximum(heq - h, 0.0), 0.0)


def scour_summary(x, y, bed, new_bed):
    """``(max scour depth (m), x, y of it)`` of *new_bed* below *bed*."""
    s = np.maximum(np.asarray(bed, float) - np.asarray(new_bed, float), 0.0)
    if not s.size or not s.max() > 0:
        return 0.0, math.nan, math.nan
    j, i = np.unravel_index(int(np.argmax(s)), s.shape)
    return float(s[j, i]), float(np.asarray(x)[i]), float(np.asarray(y)[j])
