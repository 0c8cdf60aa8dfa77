"""The hydrodynamic domain of a real site, built around its breach (issue 13, docs/theory.md, *Breach growth*, *Shallow-water equations*).

:func:`build_site` reads the terrain and the levee, places and cuts the breach, finds the flood side
and builds a :class:`~breachflow.swe.domain.Domain` along the levee at the breach, in the site CRS
rotated about the breach centre (real coordinates: a cycle file lands on the map where the levee is).
Defaults, all overridable in ``[site]``
and reported in :attr:`Site.report`:

* extent: ``B/2 + max(3 B, 30 m)`` each way along the levee, ``w + max(4 B, 40 m)`` to the flood side
  and ``w + max(3 B, 30 m)`` to the protected side (``w`` the levee half-footprint), clipped to the
  terrain — the scaled typical breach (``demo_breach``) reaches steady state in such a box;
* boundaries: the flood-side edge is the flood level (constant, or the stage of a hydrograph at the
  operation time of the cycle), absorbing with relaxation time ``4 L / sqrt(g h)`` as in
  :func:`~breachflow.swe.domain.breach_domain`; the protected-side edge free outflow; the two other
  edges walls;
* initial state: the flood side of the levee at the flood level, the polder dry.

The levee may run in any direction: the grid is built in breach-aligned coordinates
(:class:`~breachflow.site.frame.GridFrame`, the CRS rotated about the breach centre by the levee's direction there), so
that the levee at the breach runs along the grid's x axis as the closure cycle and its criteria expect;
the cycle files carry the map coordinates and GDAL's rotated geotransform (:mod:`breachflow.site.frame`). The
``nested`` solver builds its local model in the same frame from the ingested field on the CRS axes
(:class:`~breachflow.hydro.nested.FramedSampler`). Only with ``align=False`` (the frozen snapshot and plug-in
solvers, which serve a field on the CRS axes unchanged) must the levee run along the CRS x axis (within
:data:`MAX_SKEW_DEG`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..scenario.geometry import DEFAULT_WALL_SLOPE
from ..swe.domain import BoundaryCondition, Domain, uniform_grid
from .frame import GridFrame, levee_angle
from .geometry import Breach, LeveeLine, footprint_half_width, load_levee, load_polygon, side_ground
from .terrain import Terrain, load_terrain

#: largest angle (degrees) between the levee at the breach and the CRS x axis when the grid is not
#: aligned with the levee (``build_site(..., align=False)``)
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
    breach_wall_slope: float = DEFAULT_WALL_SLOPE
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
    #: grid ↔ map coordinates (rotation 0: the grid axes are the CRS axes)
    frame: GridFrame = field(default_factory=GridFrame)

    @property
    def breach_x(self) -> tuple:
        return (self.centre[0] - 0.5 * self.breach.length, self.centre[0] + 0.5 * self.breach.length)

    def terrain_at(self, X, Y):
        """``(bed, obstacle)`` at points (X, Y) in the grid coordinates: the terrain file sampled at their map
        positions with the breach cut, as :func:`build_site` builds the domain's bed, at any spacing (a nested
        grid's terrain, :func:`breachflow.hydro.nested.nested_domain`); no no-flow cells (the levee is terrain)."""
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        MX, MY = self.frame.to_map(X, Y) if self.frame.rotated else (X, Y)
        s, d = self.levee.frame(MX, MY)
        return np.minimum(self.terrain.sample(MX, MY), self.breach.cut(s, d, self.half_width)), np.zeros(X.shape, bool)

    def level_at(self, t: float) -> float:
        """Flood level (m) at operation time *t* (s): the constant level or the stage hydrograph."""
        if self.stage is None:
            return self.flood_level
        return float(np.interp(t, self.stage[0], self.stage[1]))

    def with_level(self, level: float) -> Domain:
        """The domain with the flood-side level boundary at *level* (m)."""
        from dataclasses import replace

        from ..swe.domain import _copy_spacing

        bounds = {side: [replace(bc, level=level) if bc.kind == "level" else bc for bc in bcs]
                  for side, bcs in self.domain.boundaries.items()}
        d = replace(self.domain, boundaries=bounds)
        _copy_spacing(self.domain, d)
        return d


def build_site(spec: SiteSpec, resolution: float, *, align: bool = True, terrain: Terrain | None = None,
               levee: LeveeLine | None = None) -> Site:
    """Terrain + levee + breach → :class:`Site` (errors name the file and the value; nothing is written).

    *align*: build the grid along the levee at the breach (any direction); False: along the CRS axes
    (the levee must then run within :data:`~breachflow.site.domain.MAX_SKEW_DEG` of the x axis).
    *terrain*, *levee*: already loaded from the spec's files (a breach atlas builds many sites on one
    terrain); read from the spec when not given."""
    if not resolution > 0:
        raise InputError(f"[hydro] resolution must be > 0 m, got {resolution}")
    if terrain is None:
        terrain = load_terrain(spec.terrain, crs=spec.crs, vertical_units=spec.terrain_units,
                               variable=spec.terrain_variable)
    if terrain.crs_wkt is None:  # never assumed: the levee, the breach and every output are placed in it
        raise InputError(f"{spec.terrain}: the terrain has no CRS (none in the file, no .prj beside it); state the CRS "
                         f"of its coordinates with [site] crs = \"EPSG:nnnn\" (the levee, the breach and the outputs "
                         f"are placed in it)")
    if levee is None:
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
    xc, yc = (float(v) for v in levee.point(breach.s_c))
    t = levee.tangent(breach.s_c)
    if align:
        frame = GridFrame(levee_angle(t), (xc, yc))
    else:
        skew = math.degrees(math.atan2(abs(t[1]), abs(t[0])))
        if skew > MAX_SKEW_DEG:
            raise InputError(f"{levee.source}: the levee runs at {skew:.1f}° to the x axis of the CRS at the breach "
                             f"(chainage {breach.s_c:.1f} m); this flow solver serves its field on the CRS axes and "
                             f"needs the levee within {MAX_SKEW_DEG:g}° of east–west there (the 'swe' solver takes "
                             f"any direction, and so do 'nested' and 'snapshot_frozen')")
        frame = GridFrame(0.0, (xc, yc))
    fl, fr = footprint_half_width(levee, terrain, breach.s_c, breach.bottom)
    widths = [w for w in (fl, fr) if np.isfinite(w)]
    if not widths:
        raise InputError(f"{spec.terrain}: the terrain across the breach stays above the breach bottom "
                         f"{breach.bottom:.3f} m for 200 m on both sides of the levee; check [site] breach_bottom")
    w = max(widths)
    side = _flood_side(spec, levee, terrain, breach, w, flood_level)
    # left of the line is +y (grid) when the line runs towards +x (grid)
    tx_grid = frame.vector_to_grid(t[0], t[1])[0]
    flood_sign = (1.0 if side == "left" else -1.0) * (1.0 if tx_grid > 0 else -1.0)
    B = breach.length
    along = spec.extent_along if spec.extent_along is not None else max(3.0 * B, 30.0)
    ext_f = spec.extent_flood if spec.extent_flood is not None else w + max(4.0 * B, 40.0)
    ext_p = spec.extent_protected if spec.extent_protected is not None else w + max(3.0 * B, 30.0)
    x0, x1 = xc - 0.5 * B - along, xc + 0.5 * B + along
    if flood_sign < 0:
        y0, y1 = yc - ext_f, yc + ext_p
    else:
        y0, y1 = yc - ext_p, yc + ext_f
    need = (xc - 0.5 * B - 2 * resolution, xc + 0.5 * B + 2 * resolution, yc - w, yc + w)
    box, clipped = _clip_to_terrain(frame, (x0, x1, y0, y1), need, terrain)
    if box is None:
        tb = terrain.bounds
        nx_, ny_ = frame.to_map(np.array(need[:2])[[0, 1, 1, 0]], np.array(need[2:])[[0, 0, 1, 1]])
        raise InputError(f"{spec.terrain}: the terrain (x {tb[0]:.1f}…{tb[1]:.1f}, y {tb[2]:.1f}…{tb[3]:.1f}) does not "
                         f"cover the breach and its levee footprint (x {nx_.min():.1f}…{nx_.max():.1f}, "
                         f"y {ny_.min():.1f}…{ny_.max():.1f})")
    x0, x1, y0, y1 = box
    dom = uniform_grid(x0, x1, y0, y1, resolution)
    if min(dom.shape) < 4:
        raise InputError(f"[hydro] resolution {resolution} m is too coarse for the site ({dom.shape[1]} × {dom.shape[0]} cells)")
    X, Y = np.meshgrid(dom.x, dom.y)  # grid coordinates
    MX, MY = frame.to_map(X, Y) if frame.rotated else (X, Y)  # map (CRS) coordinates
    z = terrain.sample(MX, MY)
    if not np.all(np.isfinite(z)):
        bad = np.argwhere(~np.isfinite(z))[0]
        raise InputError(f"{spec.terrain}: no elevation at ({MX[tuple(bad)]:.1f}, {MY[tuple(bad)]:.1f}) inside the "
                         f"domain around the breach (no-data cells or outside the terrain); reduce the extent")
    s, d = levee.frame(MX, MY)
    bed = np.minimum(z, breach.cut(s, d, w))
    # boundaries: flood edge level, protected edge outflow, lateral edges walls (overridable); the sides
    # are the grid's (west = -x, along the levee), which are the compass sides when the grid is not rotated
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
    if frame.rotated:
        flood_where = f"grid {flood_edge} edge, bearing {frame.bearing((0.0, flood_sign)):.0f}°"
    else:
        flood_where = flood_edge
    gx = np.array([x0, x1, x1, x0])
    gy = np.array([y0, y0, y1, y1])
    cx, cy = frame.to_map(gx, gy)
    report = {
        "terrain": str(spec.terrain), "levee": levee.source, "crs": _crs_name(terrain.crs_wkt),
        "breach_centre": (float(xc), float(yc)), "breach_chainage_m": breach.s_c, "breach_length_m": B,
        "breach_bottom_m": breach.bottom, "levee_crest_m": breach.crest, "levee_half_footprint_m": w,
        "flood_side": f"{side} of the levee line ({flood_where})", "flood_level_m": flood_level,
        "grid_rotation_deg": frame.angle_deg,
        "extent": (float(x0), float(x1), float(y0), float(y1)), "extent_clipped_to_terrain": bool(clipped),
        "extent_corners_map": [(float(a), float(b)) for a, b in zip(cx, cy)],
        "cells": f"{dom.shape[1]} x {dom.shape[0]} at {resolution:g} m", "boundaries": kinds,
        "absorbing_relaxation_s": relaxation,
    }
    return Site(domain=dom, terrain=terrain, levee=levee, breach=breach, centre=(float(xc), float(yc)),
                flood_sign=flood_sign, flood_level=flood_level, stage=stage, half_width=w, report=report, frame=frame)


def _clip_to_terrain(frame: GridFrame, box, need, terrain: Terrain):
    """The grid box ``(x0, x1, y0, y1)`` (grid coordinates) clipped so that it lies inside the terrain and
    still contains *need*; ``(box, clipped)``, or ``(None, True)`` when the terrain cannot hold *need*.

    Axis-aligned grid: each side clipped to the terrain's edges. Rotated grid: the four distances
    ``e`` from the centre to the sides are the largest that keep the box's corners inside the terrain's
    cell-centre hull (where it is sampled), a linear programme: first the largest common fraction
    ``τ`` of the way from *need* to the wanted box (no side sacrificed for another), then the largest
    ``Σ e_i / wanted_i`` at that ``τ``."""
    x0, x1, y0, y1 = box
    if not frame.rotated:
        tb = terrain.bounds
        clipped = (x0 < tb[0] or x1 > tb[1] or y0 < tb[2] or y1 > tb[3])
        x0, x1, y0, y1 = max(x0, tb[0]), min(x1, tb[1]), max(y0, tb[2]), min(y1, tb[3])
        if x0 > need[0] or x1 < need[1] or y0 > need[2] or y1 < need[3]:
            return None, True
        return (x0, x1, y0, y1), clipped
    from scipy.optimize import linprog

    cx, cy = frame.centre
    want = np.array([cx - x0, x1 - cx, cy - y0, y1 - cy])  # west, east, south, north distances
    low = np.array([cx - need[0], need[1] - cx, cy - need[2], need[3] - cy])
    lo_x, hi_x, lo_y, hi_y = terrain.x[0], terrain.x[-1], terrain.y[0], terrain.y[-1]
    c, s = math.cos(math.radians(frame.angle_deg)), math.sin(math.radians(frame.angle_deg))
    rows, rhs = [], []
    for ix, sx in ((0, -1.0), (1, 1.0)):
        for iy, sy in ((2, -1.0), (3, 1.0)):
            # corner offset (grid) = (sx e_ix, sy e_iy); map offset = R(θ) · that
            for coef_x, coef_y, lo, hi in ((c, -s, lo_x - cx, hi_x - cx), (s, c, lo_y - cy, hi_y - cy)):
                row = np.zeros(5)
                row[ix], row[iy] = coef_x * sx, coef_y * sy
                rows += [row, -row]
                rhs += [hi, -lo]
    A, b = np.array(rows), np.array(rhs)
    span = np.maximum(want - low, 0.0)
    # e_i >= low_i + τ span_i  →  -e_i + τ span_i <= -low_i
    tau_rows = np.zeros((4, 5))
    tau_rows[np.arange(4), np.arange(4)] = -1.0
    tau_rows[:, 4] = span
    bounds = [(lo_, hi_) for lo_, hi_ in zip(low, np.maximum(want, low))] + [(0.0, 1.0)]
    A1, b1 = np.vstack([A, tau_rows]), np.concatenate([b, -low])
    r1 = linprog(np.array([0, 0, 0, 0, -1.0]), A_ub=A1, b_ub=b1, bounds=bounds, method="highs")
    if r1.status != 0:
        return None, True
    tau = float(r1.x[4])
    bounds[4] = (max(tau - 1e-9, 0.0), 1.0)
    r2 = linprog(np.concatenate([-1.0 / np.maximum(want, 1e-9), [0.0]]), A_ub=A1, b_ub=b1, bounds=bounds, method="highs")
    e = (r2.x if r2.status == 0 else r1.x)[:4]
    e = np.maximum(np.minimum(e, want), low)
    clipped = bool(np.any(e < want - 1e-9))
    return (cx - e[0], cx + e[1], cy - e[2], cy + e[3]), clipped


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
        if x0 <= bad[0] <= x1 and y0 <= bad[1] <= y1:  # inside the raster: its cells there are NODATA / NaN
            n_bad = int(np.count_nonzero(~np.isfinite(zc)))
            raise InputError(f"{terrain.path}: the terrain has no elevation (NODATA / NaN cells) at the breach: "
                             f"{n_bad} of {zc.size} points of the levee line across the breach, the first at "
                             f"({bad[0]:.1f}, {bad[1]:.1f}); fill the gap in the terrain (e.g. gdal_fillnodata) or move "
                             f"the breach")
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
