"""The bed a mass rests on: a rough bed of grains (natural bed or bottom protection), its pocket geometry
and its roughness height, for the DEM contact with the terrain and for the near-bed flow
(:mod:`breachflow.fluid.nearbed`). User documentation: ``docs/bed-and-forces.md``.

Pocket (pivot) angle
--------------------
A grain of diameter ``D`` resting on a bed of grains of diameter ``d`` must be lifted over its
downstream neighbours to move. The pivot angle ``phi0`` (between the vertical and the line from the
pivot point to the grain's centre) of Wiberg & Smith (1987, Water Resour. Res. 23(8):1471–1480),
fitted by them to the measured pivot angles of natural sand of Miller & Byrne (1966, Sedimentology 6),

    ``phi0 = arccos((D/d + z*) / (D/d + 1))``,   ``z* = -0.02``,

gives about 60.7° for ``D = d`` and falls towards 0 for ``D >> d`` (a boulder on sand rests on a
near plane). Moment balance about the pivot of a grain loaded by a horizontal force ``F`` through its
centre, its submerged weight ``W'`` and a lift ``L``: it moves when ``F > tan(phi0) (W' - L)``, the
same threshold as a rolling resistance (or a sliding friction) ``mu = tan(phi0)`` on a plane
(:func:`~breachflow.dem.contact_law.rolling_law`: ``|M_r| <= mu_r R F_N``). The terrain contact takes
the pocket as a lower bound on the contact's friction and rolling resistance,
``mu_eff = max(mu_material, tan phi0(D/d))``: the mass's own resistance (its shape, from its material)
still counts on a fine bed, and on a bed of comparable grains it cannot slide or roll out of its pocket
without climbing the pivot. Kirchner et al. (1990, Sedimentology 37:647–672) measured median pivot
angles of water-worked gravel that fall with ``D/d`` as the formula does (a power ``(D/d)^-0.3`` of
Miller & Byrne's fit), with a wide spread about the median (10°–100°, Buffington et al. 1992, Water
Resour. Res. 28(2)); the model uses the median.

The terrain height field is the bed's theoretical level (the SWE's bed): a sphere of diameter ``D``
nested in a pocket of three touching spheres of ``d`` has its centre ``sqrt(((D+d)/2)^2 - d^2/3)``
above the bed grains' centres, i.e. 0.516 ``d`` above a theoretical bed level 0.2 ``d`` below the grain
tops (Einstein & El-Samni 1949) for ``D = d``, and ``D/2 + 0.2 d`` for ``D >> d``; resting on the height
field puts it at ``D/2``: within 0.02 ``D`` (``D = d``) to 0.2 ``d`` (``D >> d``).

Roughness height of the bed: ``k_s = 2 d`` (Kamphuis 1974, J. Hydraul. Res. 12(2): ``k_s = 2 D90`` for
gravel; the same ``k_s = 2 D`` as the stone-stability set-up of :mod:`breachflow.studies.stability`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: Wiberg & Smith's (1987) offset of the grain's base, fitted to Miller & Byrne's natural sand
Z_STAR = -0.02
#: roughness height per bed grain size (Kamphuis 1974)
KS_PER_GRAIN = 2.0
#: bed kinds
BED_KINDS = ("smooth", "natural", "protection")


def pivot_angle(diameter, d_bed, z_star: float = Z_STAR):
    """Pivot angle ``phi0`` (degrees) of grains *diameter* on a bed of grains *d_bed* (arrays broadcast)."""
    r = np.asarray(diameter, float) / np.asarray(d_bed, float)
    return np.degrees(np.arccos(np.clip((r + z_star) / (r + 1.0), -1.0, 1.0)))


@dataclass(frozen=True)
class BedRoughness:
    """A rough bed under the masses: ``kind`` ``natural`` (a bed of grains ``grain_size``) or
    ``protection`` (a bottom protection / mattress of stones ``grain_size`` and layer ``thickness``, a
    design element), or ``smooth`` (the plane terrain of earlier versions; no pocket).

    ``z_star`` the pivot-angle offset (Wiberg & Smith 1987); ``roughness`` the log law's ``k_s`` (default
    ``2 grain_size``)."""

    kind: str = "smooth"
    grain_size: float = 0.0
    thickness: float = 0.0
    z_star: float = Z_STAR
    roughness: float | None = None

    def __post_init__(self):
        if self.kind not in BED_KINDS:
            raise InputError(f"bed kind {self.kind!r} unknown; use one of {list(BED_KINDS)}")
        if self.kind != "smooth" and not (math.isfinite(self.grain_size) and self.grain_size > 0):
            raise InputError(f"bed kind {self.kind!r} needs grain_size > 0 m, got {self.grain_size!r}")
        if self.kind == "protection" and not (math.isfinite(self.thickness) and self.thickness >= self.grain_size):
            raise InputError(f"bottom protection: thickness must be >= its grain size {self.grain_size!r} m, "
                             f"got {self.thickness!r}")
        if not (-1.0 < self.z_star < 1.0):
            raise InputError(f"bed z_star must be in (-1, 1), got {self.z_star!r}")

    @property
    def rough(self) -> bool:
        return self.kind != "smooth"

    @property
    def ks(self) -> float | None:
        """The log law's roughness height of this bed (m), None for a smooth bed (Manning's n decides)."""
        if self.roughness is not None:
            return float(self.roughness)
        return KS_PER_GRAIN * self.grain_size if self.rough else None

    def wall_props(self, props: np.ndarray) -> np.ndarray:
        """The terrain's contact properties *props* (8 columns, as ``breachflow.dem.boundaries`` builds them)
        extended by the pocket parameters ``(d_bed, z_star)`` that the height-field contact reads; unchanged
        (8 columns, the smooth-bed path) for a smooth bed."""
        props = np.asarray(props, float)
        if not self.rough:
            return props
        return np.ascontiguousarray(np.concatenate([props[:8], [self.grain_size, self.z_star]]))

    def pocket_friction(self, diameter):
        """``tan(phi0)``: the least friction and rolling resistance of a mass *diameter* on this bed."""
        if not self.rough:
            return np.zeros_like(np.asarray(diameter, float))
        return np.tan(np.radians(pivot_angle(diameter, self.grain_size, self.z_star)))


@dataclass(frozen=True)
class ProtectionRegion:
    """A bottom protection laid over part of the bed (a mattress or a stone layer at the toe or the breach
    floor): stones of ``grain_size`` (m) in a layer ``thickness`` (m) inside ``box`` ``(x0, x1, y0, y1)`` and/or
    ``polygon`` (vertices ``(x, y)``), in the run's grid coordinates (m). Outside it the natural bed lies bare."""

    grain_size: float
    thickness: float
    box: tuple | None = None
    polygon: tuple | None = None

    def __post_init__(self):
        if not (math.isfinite(self.grain_size) and self.grain_size > 0):
            raise InputError(f"bottom protection: grain_size must be > 0 m, got {self.grain_size!r}")
        if not (math.isfinite(self.thickness) and self.thickness >= self.grain_size):
            raise InputError(f"bottom protection: thickness must be >= its grain size {self.grain_size!r} m, "
                             f"got {self.thickness!r}")
        if self.box is None and self.polygon is None:
            raise InputError("bottom protection: give its region, box = [x0, x1, y0, y1] or polygon = [[x, y], ...]")
        if self.box is not None:
            x0, x1, y0, y1 = self.box
            if not (x1 > x0 and y1 > y0):
                raise InputError(f"bottom protection: box {list(self.box)} needs x0 < x1 and y0 < y1")
        if self.polygon is not None and len(self.polygon) < 3:
            raise InputError(f"bottom protection: a polygon needs at least 3 vertices, got {len(self.polygon)}")

    def mask(self, x, y) -> np.ndarray:
        """Cells (y, x) of the grid with centres *x*, *y* (1-D) covered by the protection."""
        X, Y = np.meshgrid(np.asarray(x, float), np.asarray(y, float))
        inside = np.zeros(X.shape, bool)
        if self.box is not None:
            x0, x1, y0, y1 = self.box
            inside |= (X >= x0) & (X <= x1) & (Y >= y0) & (Y <= y1)
        if self.polygon is not None:
            from matplotlib.path import Path  # a well-tested point-in-polygon

            pts = np.column_stack([X.ravel(), Y.ravel()])
            inside |= Path(np.asarray(self.polygon, float)).contains_points(pts).reshape(X.shape)
        return inside

    def grain_map(self, x, y, d_bed: float) -> np.ndarray:
        """Grain size per cell (m): the protection's stones inside, the natural bed's *d_bed* outside."""
        return np.where(self.mask(x, y), self.grain_size, float(d_bed))
