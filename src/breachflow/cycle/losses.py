"""Masses carried out of the breach area, and the verdict when the chosen masses cannot close the breach.

The breach area
---------------
The DEM of a closure cycle keeps only the masses that can still take part in the closure: the box
``|x| <= B/2 + D_max`` along the levee and ``-(c/2 + H m_F + D_max) <= y <= c/2 + H m_P + D_max`` across
it (scene coordinates: levee centreline ``y = 0``, flood side ``y < 0``; ``B`` breach length, ``c`` crown
width, ``H`` levee height, ``m_F``/``m_P`` the slopes 1V:mH, ``D_max`` the largest mass diameter), i.e.
the levee's footprint over the breach plus one mass diameter. A mass whose centre leaves it (in practice:
rolled or carried downstream past the protected-side toe) is removed from the DEM (it costs nothing any
more) and counted as lost: number and tonnage per cycle and in total. ``[closure] area = [x0, x1, y0, y1]``
overrides the box.

Verdict
-------
A cycle that loses more than ``loss_limit`` (default 0.5) of the tonnage it placed ends the run with a
verdict instead of running into ``max_cycles``: the masses are carried away faster than they build up.
The statement names what was lost and compares the largest flow speed in the breach area ("gap speed")
with Izbash's critical speed for the masses' diameter (Izbash 1935, *Construction of dams by dumping
stones into flowing water*; Izbash & Khaldre 1970)::

    u_c = C sqrt(2 g Delta D),   Delta = (rho_s - rho_w) / rho_w,

``C = 0.86`` for a stone exposed on top of others, ``1.20`` for one embedded among them — the speed
range in which dumped stones of that size start to be carried away. Losses of more than ``loss_limit``
of all placed tonnage over the run are flagged in the summary even when the breach closes.
"""
from __future__ import annotations

import math

import numpy as np

#: Izbash coefficients (exposed stone, embedded stone)
IZBASH_C = (0.86, 1.20)
#: default fraction of a cycle's tonnage whose loss ends the run with a "not closable" verdict
LOSS_LIMIT = 0.5


def breach_area(scene, d_max: float) -> tuple[float, float, float, float]:
    """``(x0, x1, y0, y1)`` (m) of the breach area of a :class:`~breachflow.scenario.geometry.BreachScene`."""
    lev = scene.levee
    half = 0.5 * scene.breach.length + d_max
    return (-half, half, -(0.5 * lev.crown_width + lev.height * lev.flood_slope + d_max),
            0.5 * lev.crown_width + lev.height * lev.protected_slope + d_max)


def izbash_speed(diameter, density, rho_w: float = 1000.0, g: float = 9.80665, c: float = IZBASH_C[0]):
    """Izbash's critical flow speed ``C sqrt(2 g Delta D)`` (m/s) of a stone of *diameter* (m) and *density*."""
    delta = (np.asarray(density, float) - rho_w) / rho_w
    return c * np.sqrt(2.0 * g * delta * np.asarray(diameter, float))


def gap_speed(snapshot, area) -> float:
    """Largest depth-averaged speed (m/s) over wet, open cells inside the breach *area*."""
    x = snapshot["x"].values
    y = snapshot["y"].values
    X, Y = np.meshgrid(x, y)
    inside = (X >= area[0]) & (X <= area[1]) & (Y >= area[2]) & (Y <= area[3])
    wet = snapshot["depth"].values > 1e-6
    if "obstacle" in snapshot:
        wet &= ~snapshot["obstacle"].values.astype(bool)
    sel = inside & wet
    if not sel.any():
        return 0.0
    return float(np.hypot(snapshot["u"].values, snapshot["v"].values)[sel].max())


def not_closable_verdict(cycle: int, lost: int, placed: int, lost_t: float, placed_t: float, diameters,
                         density, speed: float) -> str:
    """The statement a run ends with when a cycle loses more than ``loss_limit`` of its tonnage."""
    d = np.asarray(diameters, float)
    rho = float(np.median(density))
    dtxt = f"{d.min():.3g} m" if np.ptp(d) < 1e-9 else f"{d.min():.3g}-{d.max():.3g} m"
    lo, hi = (float(izbash_speed(float(np.median(d)), rho, c=c)) for c in IZBASH_C)
    cmp = "exceeds" if speed > lo else "is below"
    return (f"not closable with D = {dtxt} masses of {rho:.0f} kg/m3: in cycle {cycle}, {lost} of {placed} masses "
            f"({lost_t:.1f} t of {placed_t:.1f} t) were carried out of the breach area; gap speed {speed:.2f} m/s "
            f"{cmp} the Izbash critical speed {lo:.2f}-{hi:.2f} m/s for D = {float(np.median(d)):.3g} m "
            f"(C = {IZBASH_C[0]}-{IZBASH_C[1]})")


def losses_flagged(lost_t: float, placed_t: float, limit: float) -> bool:
    """True when more than *limit* of the placed tonnage over the run was lost."""
    return placed_t > 0 and lost_t > limit * placed_t and math.isfinite(lost_t)
