"""Levee centreline and breach of a real site; the breach cut into the terrain (issue 13).

The levee is a polyline (GeoJSON / shapefile / GeoPackage through pyogrio, or coordinates in the
scenario). Positions along it are the chainage ``s`` (m from its first vertex) and the signed offset
``d`` (m, positive on the left of the direction of digitisation). The breach is given by its centre
chainage, length ``B`` at the crest, bottom elevation and wall slope (1V:m_W H), or by a polygon.

The cut (docs/theory.md, *Breach growth*, the trapezoid of :func:`breachflow.swe.domain.levee_bed` along the real line):
``z = min(z_terrain, z_b + max(|s − s_c| − b/2, 0) / m_W)`` (vertical walls: ``z_b`` for
``|s − s_c| ≤ B/2``), ``b = B − 2 m_W (z_crest − z_b)`` the bottom width, applied across the levee for
``|d| ≤ w`` where ``w`` is the half-width of the levee footprint above the breach bottom (from the
terrain profile across the breach centre).

Flood side: the side of the levee the flood comes from. Where the ground beside the levee (up to 100 m
beyond its footprint) is below the flood level on one side only, that side; otherwise the side whose
lowest ground (2nd percentile) is lower: the river or sea channel is deeper than the polder's ditches
(a polder is often lower than the batture, so mean ground does not tell); ``flood_side = "left" |
"right"`` overrides.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError


@dataclass
class LeveeLine:
    """The levee centreline: vertices ``(n, 2)`` in the site CRS, the CRS (WKT or None), where it came from."""

    coords: np.ndarray
    crs_wkt: str | None
    source: str

    def __post_init__(self):
        self.coords = np.asarray(self.coords, float)
        if self.coords.ndim != 2 or self.coords.shape[0] < 2 or self.coords.shape[1] < 2:
            raise InputError(f"{self.source}: the levee centreline needs at least 2 vertices (x, y)")
        self.coords = self.coords[:, :2]
        if not np.all(np.isfinite(self.coords)):
            raise InputError(f"{self.source}: the levee centreline has non-finite coordinates")
        if self.length <= 0:
            raise InputError(f"{self.source}: the levee centreline has zero length")

    @property
    def line(self):
        import shapely

        return shapely.LineString(self.coords)

    @property
    def length(self) -> float:
        return float(np.sum(np.hypot(*np.diff(self.coords, axis=0).T)))

    def point(self, s) -> np.ndarray:
        """(x, y) at chainage *s* (m)."""
        import shapely

        p = shapely.line_interpolate_point(self.line, np.asarray(s, float))
        return np.stack([shapely.get_x(p), shapely.get_y(p)], axis=-1)

    def tangent(self, s) -> np.ndarray:
        """Unit direction of the line at chainage *s* (the segment containing it)."""
        cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(self.coords, axis=0).T))])
        k = np.clip(np.searchsorted(cum, np.asarray(s, float), side="right") - 1, 0, len(self.coords) - 2)
        d = self.coords[k + 1] - self.coords[k]
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def frame(self, X, Y) -> tuple[np.ndarray, np.ndarray]:
        """Chainage ``s`` and signed offset ``d`` (left of the line positive) of points (X, Y)."""
        import shapely

        X = np.asarray(X, float)
        Y = np.asarray(Y, float)
        pts = shapely.points(X.ravel(), Y.ravel())
        line = self.line
        s = shapely.line_locate_point(line, pts)
        near = self.point(s)
        t = self.tangent(s)
        rx, ry = X.ravel() - near[:, 0], Y.ravel() - near[:, 1]
        d = np.hypot(rx, ry) * np.sign(t[:, 0] * ry - t[:, 1] * rx)
        return s.reshape(X.shape), d.reshape(X.shape)


def load_levee(path=None, *, coords=None, crs: str | None = None, source: str = "[site] levee_coords") -> LeveeLine:
    """The levee centreline from a vector file (first LineString feature; pyogrio, GeoJSON also without
    it) or from *coords* (list of ``[x, y]`` in the site CRS)."""
    if coords is not None:
        return LeveeLine(np.asarray(coords, float), crs, source)
    path = Path(path)
    if not path.exists():
        raise InputError(f"levee file not found: {path}")
    geoms, file_crs = _read_vector(path)
    lines = [g for g in geoms if g is not None and g.geom_type in ("LineString", "MultiLineString")]
    if not lines:
        raise InputError(f"{path}: no LineString feature (the levee centreline) found")
    g = lines[0]
    if g.geom_type == "MultiLineString":
        import shapely

        g = shapely.line_merge(g)
        if g.geom_type != "LineString":
            raise InputError(f"{path}: the levee MultiLineString is not one connected line")
    return LeveeLine(np.asarray(g.coords), file_crs, str(path))


def load_polygon(path):
    """The first Polygon of a vector file and its CRS (the breach outline)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"breach polygon file not found: {path}")
    geoms, file_crs = _read_vector(path)
    polys = [g for g in geoms if g is not None and g.geom_type == "Polygon"]
    if not polys:
        raise InputError(f"{path}: no Polygon feature (the breach outline) found")
    return polys[0], file_crs


def _read_vector(path: Path):
    try:
        import pyogrio

        meta, _, geom, _ = pyogrio.raw.read(path)
        import shapely

        geoms = list(shapely.from_wkb(geom))
        file_crs = meta.get("crs")
        if file_crs:
            from pyproj import CRS

            file_crs = CRS.from_user_input(file_crs).to_wkt()
        return geoms, file_crs
    except ImportError:
        pass
    except Exception as exc:
        raise InputError(f"{path}: cannot read as a vector file ({exc})") from None
    if path.suffix.lower() not in (".geojson", ".json"):
        raise InputError(f"{path}: reading {path.suffix} files needs pyogrio")
    import shapely

    try:
        doc = json.loads(path.read_text())
    except Exception as exc:
        raise InputError(f"{path}: not valid GeoJSON ({exc})") from None
    feats = doc.get("features", [doc])
    geoms = [shapely.geometry.shape(f.get("geometry", f)) for f in feats]
    name = (doc.get("crs") or {}).get("properties", {}).get("name")
    return geoms, name


@dataclass
class Breach:
    """The breach on the levee line: centre chainage ``s_c``, length ``B`` at the crest, bottom elevation
    ``z_b``, wall slope ``m_W`` (horizontal per vertical), crest elevation ``z_crest`` (from the terrain)."""

    s_c: float
    length: float
    bottom: float
    wall_slope: float
    crest: float

    @property
    def bottom_width(self) -> float:
        return self.length - 2.0 * self.wall_slope * max(self.crest - self.bottom, 0.0)

    def cut(self, s, d, half_width) -> np.ndarray:
        """Elevation of the cut at (s, d) (inf outside it)."""
        a = np.abs(np.asarray(s, float) - self.s_c)
        hb = 0.5 * self.bottom_width
        if self.wall_slope > 0:
            z = self.bottom + np.clip(a - hb, 0.0, None) / self.wall_slope
        else:
            z = np.where(a <= 0.5 * self.length, self.bottom, np.inf)
        return np.where(np.abs(d) <= half_width, z, np.inf)


def footprint_half_width(levee: LeveeLine, terrain, s_c: float, bottom: float, crest_d: float = 0.0,
                         step: float | None = None, reach: float = 200.0) -> tuple[float, float]:
    """Distances (left, right) from the centreline at which the terrain profile across the levee at
    chainage *s_c* first falls to *bottom* (the ends of the levee body the breach cuts through)."""
    p = levee.point(s_c)
    t = levee.tangent(s_c)
    n = np.array([-t[1], t[0]])  # left normal
    step = step or 0.5 * float(min(abs(terrain.x[1] - terrain.x[0]), abs(terrain.y[1] - terrain.y[0])))
    ds = np.arange(0.0, reach, step)
    out = []
    for sign in (1.0, -1.0):
        pts = p[None, :] + sign * ds[:, None] * n[None, :]
        z = terrain.sample(pts[:, 0], pts[:, 1])
        below = np.flatnonzero(~(z > bottom))
        out.append(float(ds[below[0]]) if below.size else float("nan"))
    return out[0], out[1]


def side_ground(levee: LeveeLine, terrain, s_c: float, start: float, stop: float, q: float = 50.0) -> tuple[float, float]:
    """The *q*-th percentile of the ground elevation (left, right) between offsets *start* and *stop*
    from the centreline, across the breach centre ± 10 m along the line."""
    t = levee.tangent(s_c)
    n = np.array([-t[1], t[0]])
    res = []
    for sign in (1.0, -1.0):
        vals = []
        for along in np.linspace(-10.0, 10.0, 5):
            p = levee.point(min(max(s_c + along, 0.0), levee.length))
            ds = np.linspace(start, stop, 60)
            pts = p[None, :] + sign * ds[:, None] * n[None, :]
            vals.append(terrain.sample(pts[:, 0], pts[:, 1]))
        v = np.concatenate(vals)
        res.append(float(np.nanpercentile(v, q)) if np.isfinite(v).any() else float("nan"))
    return res[0], res[1]
