"""The hydrodynamic domain of a real site, built around its breach (issue 13, SPEC §3–4).

:func:`build_site` reads the terrain and the levee, places and cuts the breach, finds the flood side
and builds an axis-aligned :class:`~breachflow.hydro.terrain.Domain` in the site CRS (real
coordinates: a cycle file lands on the map where the levee is). Defaults, all overridable in ``[site]``
and reported in :attr:`Site.report`:

* extent: ``B/2 + max(3 B, 30 m)`` each way along the levee, ``w + max(4 B, 40 m)`` to the flood side
  and ``w + max(3 B, 30 m)`` to the protected side (``w`` the levee half-footprint), clipped to the
  terrain — the scaled typical breach (``demo_breach``) reaches steady state in such a box;
* boundaries: the flood-side edge is the flood level (constant, or the stage of a hydrograph at the
  operation time of the cycle), absorbing with relaxation time ``4 L / sqrt(g h)`` as in
  :func:`~breachflow.hydro.terrain.breach_domain`; the protected-side edge free outflow; the two other
  edges walls;
* initial state: the flood side of the levee at the flood level, the polder dry.

The grid axes are the CRS axes and the closure criteria measure the breach section along x, so the
levee must run east–west (within :data:`MAX_SKEW_DEG`) at the breach.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..hydro.terrain import BoundaryCondition, Domain, uniform_grid
from .geometry import Breach, LeveeLine, footprint_half_width, load_levee, load_polygon, side_ground
from .terrain import Terrain, load_terrain

#: largest angle (degrees) between the levee at the breach and the CRS x axis
MAX_SKEW_DEG = 5.0
SIDE_KINDS = ("level", "outflow", "wall")


@dataclass
class SiteSpec:
    """A terrain site as given by the user (SI; paths absolute). See :class:`~.config.SiteTerrainSection`."""

    terrain: Path
    levee: Path | None = None
    levee_coords: list | None = None
    crs: str | None = None
    terrain_units: str | None = None
    terrain_variable: str | None = None
    breach_at: float | None = None
    breach_length: float | None = None
    breach_polygon: Path | None = None
    breach_bottom: float | None = None
    breach_wall_slope: float = 0.0
    flood_level: float | None = None
    flood_stage: Path | None = None
    flood_side: str | None = None
    manning_n: float = 0.03
    extent_along: float | None = None
    extent_flood: float | None = None
    extent_protected: float | None = None
    boundaries: dict = field(default_factory=dict)
    absorbing: bool = True
    #: the scenario file the spec came from (named in errors about its keys)
    scenario: Path | None = None


def _w(spec: SiteSpec, key: str) -> str:
    """Where a [site] key is: ``scenario.toml: [site] key``."""
    return (f"{spec.scenario}: " if spec.scenario else "") + f"[site] {key}"


@dataclass
class Site:
    """A built site: the domain and what the closure needs (centre, breach, levels), plus a report."""

    domain: Domain
    terrain: Terrain
    levee: LeveeLine
    breach: Breach
    centre: tuple
    flood_sign: float  # -1: flood side at smaller y (south), +1: larger y
    flood_level: float
    stage: tuple | None  # (times s, levels m) of a stage hydrograph, or None
    half_width: float
    report: dict

    @property
    def breach_x(self) -> tuple:
        return (self.centre[0] - 0.5 * self.breach.length, self.centre[0] + 0.5 * self.breach.length)

    def level_at(self, t: float) -> float:
        """Flood level (m) at operation time *t* (s): the constant level or the stage hydrograph."""
        if self.stage is None:
            return self.flood_level
        return float(np.interp(t, self.stage[0], self.stage[1]))

    def with_level(self, level: float) -> Domain:
        """The domain with the flood-side level boundary at *level* (m)."""
        from dataclasses import replace

        from ..hydro.terrain import _copy_spacing

        bounds = {side: [replace(bc, level=level) if bc.kind == "level" else bc for bc in bcs]
                  for side, bcs in self.domain.boundaries.items()}
        d = replace(self.domain, boundaries=bounds)
        _copy_spacing(self.domain, d)
        return d


def build_site(spec: SiteSpec, resolution: float) -> Site:
    """Terrain + levee + breach → :class:`Site` (errors name the file and the value; nothing is written)."""
    if not resolution > 0:
        raise InputError(f"[hydro] resolution must be > 0 m, got {resolution}")
    terrain = load_terrain(spec.terrain, crs=spec.crs, vertical_units=spec.terrain_units, variable=spec.terrain_variable)
    levee = load_levee(spec.levee, coords=spec.levee_coords, crs=terrain.crs_wkt if spec.levee is None else None,
                       source=_w(spec, "levee_coords"))
    _check_crs(terrain, levee)
    _check_crosses(terrain, levee)
    stage = None
    if spec.flood_stage is not None:
        from ..scenario.hydrograph import read_series_csv

        t, z, _ = read_series_csv(spec.flood_stage, kind="length")
        stage = (t - t[0], z)
        flood_level = float(np.max(z))
    elif spec.flood_level is not None:
        flood_level = float(spec.flood_level)
    else:
        raise InputError("[site]: give flood_level or flood_stage (the water level on the flood side)")
    breach = _place_breach(spec, terrain, levee)
    if not flood_level > breach.bottom:
        src = spec.flood_stage or f"{_w(spec, 'flood_level')}"
        raise InputError(f"{src}: flood level {flood_level:.3f} m is not above the breach bottom "
                         f"{breach.bottom:.3f} m ([site] breach_bottom): no water flows through the breach")
    xc, yc = levee.point(breach.s_c)
    t = levee.tangent(breach.s_c)
    skew = math.degrees(math.atan2(abs(t[1]), abs(t[0])))
    if skew > MAX_SKEW_DEG:
        raise InputError(f"{levee.source}: the levee runs at {skew:.1f}° to the x axis of the CRS at the breach "
                         f"(chainage {breach.s_c:.1f} m); the grid is built along the CRS axes and needs the levee "
                         f"within {MAX_SKEW_DEG:g}° of east–west there")
    fl, fr = footprint_half_width(levee, terrain, breach.s_c, breach.bottom)
    widths = [w for w in (fl, fr) if np.isfinite(w)]
    if not widths:
        raise InputError(f"{spec.terrain}: the terrain across the breach stays above the breach bottom "
                         f"{breach.bottom:.3f} m for 200 m on both sides of the levee; check [site] breach_bottom")
    w = max(widths)
    side = _flood_side(spec, levee, terrain, breach, w, flood_level)
    # left of the line is +y when the line runs east (t_x > 0)
    flood_sign = (1.0 if side == "left" else -1.0) * (1.0 if t[0] > 0 else -1.0)
    B = breach.length
    along = spec.extent_along if spec.extent_along is not None else max(3.0 * B, 30.0)
    ext_f = spec.extent_flood if spec.extent_flood is not None else w + max(4.0 * B, 40.0)
    ext_p = spec.extent_protected if spec.extent_protected is not None else w + max(3.0 * B, 30.0)
    x0, x1 = xc - 0.5 * B - along, xc + 0.5 * B + along
    if flood_sign < 0:
        y0, y1 = yc - ext_f, yc + ext_p
    else:
        y0, y1 = yc - ext_p, yc + ext_f
    tb = terrain.bounds
    clipped = (x0 < tb[0] or x1 > tb[1] or y0 < tb[2] or y1 > tb[3])
    x0, x1, y0, y1 = max(x0, tb[0]), min(x1, tb[1]), max(y0, tb[2]), min(y1, tb[3])
    need = (xc - 0.5 * B - 2 * resolution, xc + 0.5 * B + 2 * resolution, yc - w, yc + w)
    if x0 > need[0] or x1 < need[1] or y0 > need[2] or y1 < need[3]:
        raise InputError(f"{spec.terrain}: the terrain (x {tb[0]:.1f}…{tb[1]:.1f}, y {tb[2]:.1f}…{tb[3]:.1f}) does not "
                         f"cover the breach and its levee footprint (x {need[0]:.1f}…{need[1]:.1f}, y {need[2]:.1f}…{need[3]:.1f})")
    dom = uniform_grid(x0, x1, y0, y1, resolution)
    if min(dom.shape) < 4:
        raise InputError(f"[hydro] resolution {resolution} m is too coarse for the site ({dom.shape[1]} × {dom.shape[0]} cells)")
    X, Y = np.meshgrid(dom.x, dom.y)
    z = terrain.sample(X, Y)
    if not np.all(np.isfinite(z)):
        bad = np.argwhere(~np.isfinite(z))[0]
        raise InputError(f"{spec.terrain}: no elevation at ({dom.x[bad[1]]:.1f}, {dom.y[bad[0]]:.1f}) inside the "
                         f"domain around the breach (no-data cells or outside the terrain); reduce the extent")
    s, d = levee.frame(X, Y)
    bed = np.minimum(z, breach.cut(s, d, w))
    # boundaries: flood edge level, protected edge outflow, lateral edges walls (overridable)
    flood_edge, prot_edge = ("south", "north") if flood_sign < 0 else ("north", "south")
    kinds = {"west": "wall", "east": "wall", flood_edge: "level", prot_edge: "outflow"}
    for k, v in spec.boundaries.items():
        if k not in kinds:
            raise InputError(f"{_w(spec, 'boundaries')}: unknown side {k!r}; use west, east, south, north")
        if v not in SIDE_KINDS:
            raise InputError(f"{_w(spec, 'boundaries')}.{k} = {v!r}; use one of {SIDE_KINDS}")
        kinds[k] = v
    relaxation = None
    if spec.absorbing:
        relaxation = 4.0 * ext_f / math.sqrt(9.81 * max(flood_level - breach.bottom, 1e-3))
    bcs = {}
    for k, kind in kinds.items():
        if kind == "level":
            bcs[k] = [BoundaryCondition.water_level(flood_level if stage is None else float(stage[1][0]),
                                                    absorbing=relaxation)]
        elif kind == "outflow":
            bcs[k] = [BoundaryCondition.outflow()]
        else:
            bcs[k] = [BoundaryCondition.wall()]
    level0 = flood_level if stage is None else float(stage[1][0])
    flood_cells = (Y - yc) * flood_sign > w
    dom.bed = bed
    dom.manning = np.full(dom.shape, float(spec.manning_n))
    dom.initial_surface = np.where(flood_cells & (bed < level0), level0, np.nan)
    dom.boundaries = bcs
    dom.name = f"site {Path(spec.terrain).name}"
    dom.crs_wkt = terrain.crs_wkt
    report = {
        "terrain": str(spec.terrain), "levee": levee.source, "crs": _crs_name(terrain.crs_wkt),
        "breach_centre": (float(xc), float(yc)), "breach_chainage_m": breach.s_c, "breach_length_m": B,
        "breach_bottom_m": breach.bottom, "levee_crest_m": breach.crest, "levee_half_footprint_m": w,
        "flood_side": f"{side} of the levee line ({flood_edge})", "flood_level_m": flood_level,
        "extent": (float(x0), float(x1), float(y0), float(y1)), "extent_clipped_to_terrain": bool(clipped),
        "cells": f"{dom.shape[1]} x {dom.shape[0]} at {resolution:g} m", "boundaries": kinds,
        "absorbing_relaxation_s": relaxation,
    }
    return Site(domain=dom, terrain=terrain, levee=levee, breach=breach, centre=(float(xc), float(yc)),
                flood_sign=flood_sign, flood_level=flood_level, stage=stage, half_width=w, report=report)


def _crs_name(wkt):
    if not wkt:
        return "none"
    from pyproj import CRS

    c = CRS.from_wkt(wkt)
    epsg = c.to_epsg()
    return f"{c.name}" + (f" (EPSG:{epsg})" if epsg else "")


def _check_crs(terrain: Terrain, levee: LeveeLine):
    if terrain.crs_wkt is None or levee.crs_wkt is None:
        return
    from pyproj import CRS

    a, b = CRS.from_user_input(terrain.crs_wkt), CRS.from_user_input(levee.crs_wkt)
    if not a.equals(b, ignore_axis_order=True):
        raise InputError(f"CRS mismatch: the terrain {terrain.path} is in {_crs_name(terrain.crs_wkt)} but the levee "
                         f"{levee.source} is in {_crs_name(levee.crs_wkt)}; reproject one of them")


def _check_crosses(terrain: Terrain, levee: LeveeLine):
    import shapely

    x0, x1, y0, y1 = terrain.bounds
    box = shapely.box(x0, y0, x1, y1)
    if not levee.line.intersects(box):
        lx, ly = levee.coords[:, 0], levee.coords[:, 1]
        raise InputError(f"{levee.source}: the levee line (x {lx.min():.1f}…{lx.max():.1f}, y {ly.min():.1f}…{ly.max():.1f}) "
                         f"does not cross the terrain {terrain.path} (x {x0:.1f}…{x1:.1f}, y {y0:.1f}…{y1:.1f}); "
                         f"wrong file or CRS?")


def _place_breach(spec: SiteSpec, terrain: Terrain, levee: LeveeLine) -> Breach:
    if spec.breach_bottom is None:
        raise InputError(f"{_w(spec, 'breach_bottom')} (elevation of the breach bottom) is required")
    if spec.breach_polygon is not None:
        import shapely

        poly, pcrs = load_polygon(spec.breach_polygon)
        if pcrs and terrain.crs_wkt:
            from pyproj import CRS

            if not CRS.from_user_input(pcrs).equals(CRS.from_user_input(terrain.crs_wkt), ignore_axis_order=True):
                raise InputError(f"CRS mismatch: the terrain {terrain.path} is in {_crs_name(terrain.crs_wkt)} but the "
                                 f"breach polygon {spec.breach_polygon} is in {_crs_name(pcrs)}")
        inside = levee.line.intersection(poly)
        if inside.is_empty or inside.length <= 0:
            raise InputError(f"{spec.breach_polygon}: the breach polygon does not cross the levee line {levee.source}")
        pts = shapely.points(np.asarray(shapely.get_coordinates(inside)))
        ss = shapely.line_locate_point(levee.line, pts)
        s0, s1 = float(ss.min()), float(ss.max())
        s_c, length = 0.5 * (s0 + s1), s1 - s0
    else:
        if spec.breach_at is None or spec.breach_length is None:
            raise InputError("[site]: give breach_at (chainage along the levee) and breach_length, or breach_polygon")
        s_c, length = float(spec.breach_at), float(spec.breach_length)
        if not length > 0:
            raise InputError(f"{_w(spec, 'breach_length')} must be > 0 m, got {length}")
        if length > levee.length:
            raise InputError(f"{_w(spec, 'breach_length')} = {length:g} m is longer than the levee {levee.source} "
                             f"({levee.length:.1f} m)")
        if s_c - 0.5 * length < 0 or s_c + 0.5 * length > levee.length:
            raise InputError(f"{_w(spec, 'breach_at')} = {s_c:g} m with breach_length = {length:g} m runs off the levee "
                             f"{levee.source} (0…{levee.length:.1f} m along the line)")
    ss = np.linspace(s_c - 0.5 * length, s_c + 0.5 * length, max(int(length / 0.25), 5))
    p = levee.point(ss)
    zc = terrain.sample(p[:, 0], p[:, 1])
    if not np.all(np.isfinite(zc)):
        bad = p[np.flatnonzero(~np.isfinite(zc))[0]]
        x0, x1, y0, y1 = terrain.bounds
        raise InputError(f"{terrain.path}: the terrain (x {x0:.1f}…{x1:.1f}, y {y0:.1f}…{y1:.1f}) does not cover the "
                         f"breach (no elevation at ({bad[0]:.1f}, {bad[1]:.1f}) on the levee line)")
    crest = float(np.max(zc))
    if not spec.breach_bottom < crest:
        raise InputError(f"{_w(spec, 'breach_bottom')} = {spec.breach_bottom:g} m is not below the levee crest "
                         f"({crest:.2f} m in {terrain.path})")
    br = Breach(s_c=s_c, length=length, bottom=float(spec.breach_bottom), wall_slope=float(spec.breach_wall_slope),
                crest=crest)
    if br.bottom_width <= 0:
        raise InputError(f"{_w(spec, 'breach_wall_slope')} = {spec.breach_wall_slope:g}: the walls meet above the bottom "
                         f"(length {length:g} m, depth {crest - br.bottom:.2f} m)")
    return br


def _flood_side(spec, levee, terrain, breach, w, flood_level) -> str:
    if spec.flood_side is not None:
        if spec.flood_side not in ("left", "right"):
            raise InputError(f"{_w(spec, 'flood_side')} = {spec.flood_side!r}; use 'left' or 'right' (of the levee line's direction)")
        return spec.flood_side
    gl, gr = side_ground(levee, terrain, breach.s_c, w + 1.0, w + 100.0, q=2.0)
    wet_l, wet_r = gl < flood_level, gr < flood_level
    if wet_l != wet_r:
        return "left" if wet_l else "right"
    if not (np.isfinite(gl) and np.isfinite(gr)):
        raise InputError(f"{terrain.path}: cannot tell the flood side (no terrain beside the levee); set [site] flood_side")
    if gl == gr:
        raise InputError(f"{terrain.path}: cannot tell the flood side (same ground on both sides); set [site] flood_side")
    return "left" if gl < gr else "right"
