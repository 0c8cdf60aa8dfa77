"""Physical sanity of a closure scenario, checked before anything runs (and counted after).

:func:`check_setup` refuses (``InputError`` naming the scenario key and value) what cannot work:

* masses not heavier than water (``[placement] density`` <= 1000 kg/m³): they float, nothing settles;
* masses wider than the breach (``diameter`` > breach length): they cannot enter the gap;
* release points outside the hydrodynamic domain (``zone``, ``points``, ``start``/``stop``).

and returns warnings for what is suspicious but possible:

* masses wider than the release line (the line is shorter than a mass: every mass lands in one spot);
* batches that cannot fit side by side on the release line (``batch`` × smallest diameter > line length +
  largest diameter): the batch is stacked vertically on release.

After the run, :func:`outcome_warnings` counts the masses that left the domain and those that never came
to rest (still moving when the last cycle's DEM time ran out), and compares the mass size with Izbash's
stone size for the first solve's peak speed.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

WATER_DENSITY = 1000.0


def check_setup(setup) -> list[str]:
    """Refuse impossible placements (InputError); return warnings (strings) for suspicious ones."""
    pl = setup.placement
    warnings: list[str] = []
    if pl.density[0] <= WATER_DENSITY:
        raise InputError(f"[placement] density: masses of {pl.density[0]:g} kg/m³ are not heavier than water "
                         f"({WATER_DENSITY:g} kg/m³): they float and never settle in the breach")
    breach = float(setup.breach_x[1] - setup.breach_x[0])
    if breach > 0 and pl.diameter[1] > breach:
        raise InputError(f"[placement] diameter: masses up to {pl.diameter[1]:g} m are wider than the breach "
                         f"({breach:g} m)")
    dom = setup.domain
    dx, dy = dom.dx, dom.dy
    x0, x1 = dom.x[0] - 0.5 * dx, dom.x[-1] + 0.5 * dx
    y0, y1 = dom.y[0] - 0.5 * dy, dom.y[-1] + 0.5 * dy

    def outside(pts):
        pts = np.atleast_2d(np.asarray(pts, float))
        return pts[(pts[:, 0] < x0) | (pts[:, 0] > x1) | (pts[:, 1] < y0) | (pts[:, 1] > y1)]

    if pl.positions not in ("zone", "list"):  # line, vertical, horizontal: the line start→stop
        for key, pt in (("start", pl.start), ("stop", pl.stop)):
            if outside([pt]).size:
                raise InputError(f"placement.{key}: release point {list(pt)} lies outside the domain "
                                 f"x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m")
        length = float(np.hypot(pl.stop[0] - pl.start[0], pl.stop[1] - pl.start[1]))
        if length < pl.diameter[1]:
            warnings.append(f"[placement] the release line ({length:g} m) is shorter than the masses "
                            f"(up to {pl.diameter[1]:g} m): every mass is dropped at about the same spot")
        if pl.positions == "line" and pl.batch > 1 and pl.batch * pl.diameter[0] > length + pl.diameter[1]:
            warnings.append(f"[placement] a batch of {pl.batch} masses of {pl.diameter[0]:g}-{pl.diameter[1]:g} m "
                            f"does not fit side by side on the {length:g} m release line: the batch is stacked "
                            "vertically on release")
    elif pl.positions == "zone":
        zx0, zx1, zy0, zy1 = pl.zone
        bad = outside([(zx0, zy0), (zx1, zy1)])
        if bad.size:
            raise InputError(f"placement.zone {list(pl.zone)} reaches outside the domain "
                             f"x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m")
        area = abs(zx1 - zx0) * abs(zy1 - zy0)
        if pl.batch * pl.diameter[0] ** 2 > area + pl.diameter[1] ** 2:
            warnings.append(f"[placement] a batch of {pl.batch} masses of {pl.diameter[0]:g} m does not fit side by "
                            f"side in the {area:g} m² release zone: the batch is stacked vertically on release")
    else:
        bad = outside(pl.points)
        if bad.size:
            raise InputError(f"placement.points {bad.tolist()} lie outside the domain "
                             f"x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m")
    return warnings


def outcome_warnings(left_domain: int, not_at_rest: int, masses: int, mass_diameter=None, izbash_diameter=None) -> list[str]:
    """Warnings with counts for the closure summary."""
    out = []
    if left_domain:
        out.append(f"{left_domain} of {masses} masses left the domain (carried away)")
    if not_at_rest:
        out.append(f"{not_at_rest} of {masses} masses were still moving when the last cycle's DEM time ran out")
    if mass_diameter is not None and izbash_diameter is not None and mass_diameter < izbash_diameter:
        out.append(f"masses of {mass_diameter:.2f} m are smaller than Izbash's exposed stone size "
                   f"{izbash_diameter:.2f} m for the peak speed: expect them to be carried away")
    return out
