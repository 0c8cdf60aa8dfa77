"""Stone size and rock quantity for a closure, before any simulation (closure-engineering rules).

Stone stability, with ``Delta = (rho_S - rho_W) / rho_W`` the relative submerged density:

* **Izbash** (Izbash & Khaldre 1970; USACE EM 1110-2-1601; CIRIA/CUR/CETMEF *Rock Manual* 2007
  §5.2.1.3): a stone of diameter ``D`` starts to move at the velocity ``U_c = C sqrt(2 g Delta D)``,
  ``C = 0.86`` for an exposed stone (on top of a dumped pile), ``C = 1.20`` for an embedded one. Hence
  ``D = U^2 / (2 g Delta C^2)``.
* **Shields** with a logarithmic velocity profile over a rock bed: critical Shields parameter
  ``theta_c = u*^2 / (g Delta D)`` (default 0.047, Meyer-Peter & Müller; 0.03–0.055 are used for rock), and
  the depth-averaged velocity of a rough log-law flow ``U = (u*/kappa) (ln(30 h/k_s) - 1)`` with
  ``k_s = 2 D`` (the same depth-averaged log law as :mod:`breachflow.fluid.profile`). ``U_c(D)`` grows
  with ``D``; the stable size is the root of ``U_c(D) = U``.

Rock quantity: a trapezoidal dam in the breach, from the breach bottom to ``height`` (default the breach
depth), crest width ``crest_width`` (default ``max(3 D, 1 m)``), side slopes ``1V:side_slope H`` up- and
downstream; the breach widens upwards with its wall slope (``wall_slope`` H per V, 0 = vertical; default
:data:`~breachflow.scenario.geometry.DEFAULT_WALL_SLOPE`). Bulk
volume ``V = int_0^H (b_c + 2 m (H - z)) (B + 2 m_W z) dz``; solid rock ``(1 - n) V``; mass
``rho_S (1 - n) V``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..units import to_si

#: porosity of a dumped pile of equal spheres / rock fill where neither the material nor ``[placement]
#: porosity`` states it (random loose packing of spheres is 0.40–0.42; dumped rock 0.35–0.40, Rock Manual §3.5)
DUMPED_POROSITY = 0.40
#: side slopes of a dumped dam, H per V (1V:1.5H), where ``[placement] side_slope`` does not state them
DEFAULT_SIDE_SLOPE = 1.5
from .geometry import DEFAULT_WALL_SLOPE

G = 9.80665
KAPPA = 0.41
IZBASH = {"exposed": 0.86, "embedded": 1.20}


def _delta(rho_s, rho_w):
    if not rho_s > rho_w:
        raise InputError(f"stone density {rho_s} kg/m^3 must exceed the water density {rho_w} kg/m^3 "
                         "(a lighter mass floats)")
    return (rho_s - rho_w) / rho_w


def izbash_velocity(diameter, density=2650.0, *, placement="exposed", water_density=1000.0, gravity=G):
    """Izbash critical velocity ``C sqrt(2 g Delta D)`` (m/s); *placement* ``exposed`` (0.86) | ``embedded`` (1.2)."""
    if placement not in IZBASH:
        raise InputError(f"Izbash placement {placement!r} unknown; use one of {sorted(IZBASH)}")
    d = _delta(density, water_density)
    return IZBASH[placement] * np.sqrt(2.0 * gravity * d * np.asarray(diameter, float))


def shields_velocity(diameter, depth, density=2650.0, *, theta_c=0.047, roughness_factor=2.0,
                     water_density=1000.0, gravity=G):
    """Depth-averaged velocity (m/s) at which a bed of stones *diameter* in water *depth* reaches the
    critical Shields parameter: ``sqrt(theta_c g Delta D) (ln(30 h / (r D)) - 1) / kappa`` with ``k_s = r D``."""
    d = _delta(density, water_density)
    D = np.asarray(diameter, float)
    h = np.asarray(depth, float)
    ln = np.log(30.0 * h / (roughness_factor * D)) - 1.0
    return np.sqrt(theta_c * gravity * d * D) * np.maximum(ln, 0.0) / KAPPA


def izbash_diameter(velocity, density=2650.0, *, placement="exposed", water_density=1000.0, gravity=G):
    """Stone diameter (m) stable at *velocity* by Izbash: ``U^2 / (2 g Delta C^2)``."""
    if placement not in IZBASH:
        raise InputError(f"Izbash placement {placement!r} unknown; use one of {sorted(IZBASH)}")
    d = _delta(density, water_density)
    return np.asarray(velocity, float) ** 2 / (2.0 * gravity * d * IZBASH[placement] ** 2)


def shields_diameter(velocity, depth, density=2650.0, *, theta_c=0.047, roughness_factor=2.0,
                     water_density=1000.0, gravity=G) -> float:
    """Stone diameter (m) whose critical depth-averaged velocity (:func:`shields_velocity`) is *velocity*."""
    from scipy.optimize import brentq

    u, h = float(velocity), float(depth)
    if not (u > 0 and h > 0):
        raise InputError(f"velocity and depth must be > 0, got {u} m/s, {h} m")
    f = lambda D: shields_velocity(D, h, density, theta_c=theta_c, roughness_factor=roughness_factor,  # noqa: E731
                                   water_density=water_density, gravity=gravity) - u
    hi = 30.0 * h / roughness_factor / math.e * 0.999  # ln(...) - 1 = 0 above: U_c -> 0
    lo = 1e-6
    # U_c rises from 0 and falls back to 0 at `hi`; take the rising branch (the physical root)
    grid = np.geomspace(lo, hi, 400)
    vals = np.array([f(D) for D in grid])
    k = int(np.argmax(vals))
    if vals[k] < 0:
        raise InputError(f"no stone is stable at {u} m/s in {h} m of water by Shields (the maximum critical "
                         f"velocity there is {vals[k] + u:.2f} m/s for D = {grid[k]:.2f} m)")
    return float(brentq(f, lo, grid[k]))


@dataclass
class StoneEstimate:
    """Result of :func:`stone_size` (SI)."""

    velocity: float
    depth: float
    density: float
    d_izbash_exposed: float
    d_izbash_embedded: float
    d_shields: float
    design_diameter: float
    stone_mass: float
    bulk_volume: float
    rock_volume: float
    tonnage: float
    porosity: float
    side_slope: float
    crest_width: float
    height: float
    breach_length: float

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def fill_volume(breach_length, height, crest_width, side_slope, wall_slope=DEFAULT_WALL_SLOPE) -> float:
    """Bulk volume (m³) of a trapezoidal dam filling the breach up to *height* (see module docstring)."""
    B, H, b, m, mw = (float(v) for v in (breach_length, height, crest_width, side_slope, wall_slope))
    # int_0^H (b + 2 m (H - z)) (B + 2 mw z) dz, in closed form
    return (b * B * H + b * mw * H ** 2 + m * B * H ** 2 + (2.0 / 3.0) * m * mw * H ** 3)


def stone_size(velocity, depth, breach_length, *, breach_depth=None, density="2650 kg/m^3",
               porosity=DUMPED_POROSITY, side_slope=DEFAULT_SIDE_SLOPE, crest_width=None, wall_slope=DEFAULT_WALL_SLOPE, theta_c=0.047, water_density="1000 kg/m^3",
               safety="exposed") -> StoneEstimate:
    """Izbash/Shields stone size and the rock to fill the breach cross-section.

    *velocity* the design (peak) flow velocity in the gap, *depth* the water depth there; the dam is
    *breach_length* long at the bottom and *breach_depth* high (default *depth*). The design diameter is
    the larger of Izbash-*safety* (``exposed`` by default: stones dumped on a pile) and Shields.
    Every quantity accepts units.
    """
    u = to_si(velocity, name="velocity", kind="speed", default_unit="m/s", positive=True)
    h = to_si(depth, name="depth", kind="length", default_unit="m", positive=True)
    B = to_si(breach_length, name="breach_length", kind="length", default_unit="m", positive=True)
    H = h if breach_depth is None else to_si(breach_depth, name="breach_depth", kind="length", default_unit="m",
                                             positive=True)
    rho = to_si(density, name="density", kind="density", default_unit="kg/m^3", positive=True)
    rho_w = to_si(water_density, name="water_density", kind="density", default_unit="kg/m^3", positive=True)
    n = float(porosity)
    if not 0.0 <= n < 1.0:
        raise InputError(f"porosity must be in [0, 1), got {porosity!r}")
    m = float(side_slope)
    if not m >= 0:
        raise InputError(f"side_slope must be >= 0 (H per V), got {side_slope!r}")
    d_ex = float(izbash_diameter(u, rho, placement="exposed", water_density=rho_w))
    d_em = float(izbash_diameter(u, rho, placement="embedded", water_density=rho_w))
    d_sh = shields_diameter(u, h, rho, theta_c=theta_c, water_density=rho_w)
    d_design = max(d_ex if safety == "exposed" else d_em, d_sh)
    b = max(3.0 * d_design, 1.0) if crest_width is None else to_si(crest_width, name="crest_width", kind="length",
                                                                   default_unit="m", nonnegative=True)
    V = fill_volume(B, H, b, m, float(wall_slope))
    rock = (1.0 - n) * V
    return StoneEstimate(velocity=u, depth=h, density=rho, d_izbash_exposed=d_ex, d_izbash_embedded=d_em,
                         d_shields=d_sh, design_diameter=d_design, stone_mass=rho * math.pi / 6.0 * d_design ** 3,
                         bulk_volume=V, rock_volume=rock, tonnage=rho * rock / 1000.0, porosity=n, side_slope=m,
                         crest_width=b, height=H, breach_length=B)
