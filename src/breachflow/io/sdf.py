"""HEC-RAS GIS export (``RASExport.sdf``) → mesh snapshot over the cross-section cut lines.

The file is parsed by ``hydro/io/sdf_parser.py`` (the grammar, :func:`read_sdf`; re-exported here).

How the 1-D results become a 2-D snapshot (the interpolation method):

* nodes: on each cut line, at the surface-line points and at every velocity fraction of any profile;
  fractions are measured along the cut line's plan length;
* bed: linear in fraction between surface-line points (``NULL`` elevations dropped);
* depth per profile: ``WATER ELEVATION − bed`` (≤ 0 is dry);
* velocity: magnitude linear in fraction between the listed ``VELOCITIES`` points (0 outside them),
  directed along the cut line's normal pointing downstream (1-D flow is normal to the section;
  downstream from the reach centerline, else from decreasing river station);
* faces: triangles zipped between consecutive cross sections (by station) of the same reach, so values
  between sections are barycentric (linear) interpolations of the two sections' values;
* time: one step per profile; timestamps (``01JAN2020 0100``) become datetimes, other names
  (``PF 1``) keep an integer profile index and are listed in ``profile_name``.
"""
from __future__ import annotations

import warnings
from datetime import datetime
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, InputError, ParseError
from .sdf_parser import KEYWORDS, CrossSection, Reach, SdfData, read_sdf

__all__ = ["open_sdf", "read_sdf", "SdfData", "CrossSection", "Reach", "KEYWORDS"]


def _polyline_at(points: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    seg = np.hypot(*np.diff(points, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = fractions * cum[-1]
    return np.column_stack([np.interp(s, cum, points[:, 0]), np.interp(s, cum, points[:, 1])])


def _fractions_along(points: np.ndarray) -> np.ndarray:
    seg = np.hypot(*np.diff(points, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    return cum / cum[-1] if cum[-1] > 0 else cum


def _merge_fractions(exact, approx, tol: float = 1e-3) -> np.ndarray:
    """Union of node fractions; a surface-line fraction within *tol* of another one (coordinates are
    rounded in the file) is the same node, exact velocity fractions taking precedence."""
    out = list(exact)
    for f in approx:
        if not out or np.min(np.abs(np.asarray(out) - f)) > tol:
            out.append(float(f))
    return np.array(sorted(out))


def _zip(a: np.ndarray, b: np.ndarray, ia: np.ndarray, ib: np.ndarray) -> list:
    """Triangulate the strip between two node rows with fractions *a*, *b* (both sorted)."""
    tris = []
    i = j = 0
    while i < len(a) - 1 or j < len(b) - 1:
        if j == len(b) - 1 or (i < len(a) - 1 and a[i + 1] <= b[j + 1]):
            tris.append((ia[i], ib[j], ia[i + 1]))
            i += 1
        else:
            tris.append((ia[i], ib[j], ib[j + 1]))
            j += 1
    return tris


def _parse_profile_times(names):
    out = []
    for n in names:
        for fmt in ("%d%b%Y %H%M", "%d%b%Y %H:%M", "%d%b%Y %H%M%S", "%d%b%Y"):
            try:
                out.append(datetime.strptime(n.strip().upper().title().replace(" ", " "), fmt))
                break
            except ValueError:
                continue
        else:
            return None
    return np.array(out, dtype="datetime64[ns]")


def open_sdf(paths, *, units=None, crs=None, plausibility="raise", strict=False, **unused):
    """HEC-RAS ``.sdf`` → mesh snapshot (SI); see the module doc for the interpolation method."""
    from ..units import ureg
    from ..field.snapshot import check_plausibility, mesh_snapshot
    from . import read_prj, unknown_options

    unknown_options("sdf", unused)
    paths = [Path(p) for p in paths]
    sdfs = [p for p in paths if p.suffix.lower() == ".sdf"]
    prjs = [p for p in paths if p.suffix.lower() == ".prj"]
    if len(sdfs) != 1 or len(sdfs) + len(prjs) != len(paths):
        raise InputError("sdf reader: give exactly one .sdf file (and optionally a .prj)")
    data = read_sdf(sdfs[0], strict=strict)
    file_unit = {"US CUSTOMARY": "ft", "METRIC": "m"}.get(data.header.get("UNITS", "").strip().upper())
    if "UNITS" in data.header and file_unit is None:
        raise ParseError(f"UNITS {data.header['UNITS']!r} is neither US CUSTOMARY nor METRIC", path=data.path)
    if units is not None:
        if file_unit and ureg.Quantity(1, str(units)).to("m").magnitude != ureg.Quantity(1, file_unit).to("m").magnitude:
            warnings.warn(f"units={units!r} overrides the file's UNITS: {data.header['UNITS']}", BreachflowWarning, stacklevel=2)
        unit = str(units)
    elif file_unit:
        unit = file_unit
    else:
        raise InputError(f"{data.path}: no UNITS in the header; pass units='m' or 'ft'")
    to_m = float(ureg.Quantity(1.0, unit).to("m").magnitude)
    if not data.sections:
        raise InputError(f"{data.path}: no cross sections")
    if not data.profiles:
        raise InputError(f"{data.path}: no profiles (NUMBER OF PROFILES / PROFILE NAMES)")
    nprof = len(data.profiles)
    xs_nodes = []  # per XS: (fractions, xy, bed, wse per profile, speed per profile, normal)
    for xs in data.sections:
        cut = np.asarray(xs.cut, dtype=float)
        surf = np.asarray(xs.surface, dtype=float) if xs.surface else np.empty((0, 3))
        ok = np.isfinite(surf[:, 2]) if surf.size else np.zeros(0, bool)
        if ok.sum() < 2:
            raise ParseError(f"cross section {xs.station_text}: surface line needs at least 2 points with elevations",
                             path=data.path, line=xs.line)
        sf = _fractions_along(surf[:, :2])
        vel_fr = sorted({f for pts in xs.velocities.values() for f, _ in pts})
        fr = _merge_fractions(vel_fr, sf)
        xy = _polyline_at(cut, fr)
        bed = np.interp(fr, sf[ok], surf[ok, 2])
        speed = np.zeros((nprof, fr.size))
        for k, name in enumerate(data.profiles):
            pts = xs.velocities.get(name)
            if pts:
                pf = np.array([p[0] for p in pts])
                pv = np.array([p[1] for p in pts])
                order = np.argsort(pf)
                speed[k] = np.interp(fr, pf[order], pv[order], left=0.0, right=0.0)
        wse = np.asarray(xs.water, dtype=float)
        d = cut[-1] - cut[0]
        normal = np.array([d[1], -d[0]]) / np.hypot(*d)  # right-hand normal of the cut line
        xs_nodes.append(dict(fr=fr, xy=xy, bed=bed, wse=wse, speed=speed, normal=normal, xs=xs))
    _orient_downstream(xs_nodes, data)
    # nodes and faces
    offsets = np.cumsum([0] + [n["fr"].size for n in xs_nodes])
    groups: dict[tuple, list[int]] = {}
    for i, n in enumerate(xs_nodes):
        groups.setdefault((n["xs"].stream, n["xs"].reach), []).append(i)
    tris = []
    for members in groups.values():
        members.sort(key=lambda i: -xs_nodes[i]["xs"].station)
        for a, b in zip(members[:-1], members[1:]):
            na, nb = xs_nodes[a], xs_nodes[b]
            tris += _zip(na["fr"], nb["fr"], offsets[a] + np.arange(na["fr"].size), offsets[b] + np.arange(nb["fr"].size))
    if not tris:
        raise InputError(f"{data.path}: need at least two cross sections on one reach to span a mesh")
    xy = np.concatenate([n["xy"] for n in xs_nodes]) * to_m
    bed = np.concatenate([n["bed"] for n in xs_nodes]) * to_m
    faces = np.asarray(tris, dtype=np.int64)
    a, b, c = faces.T
    area2 = (xy[b, 0] - xy[a, 0]) * (xy[c, 1] - xy[a, 1]) - (xy[c, 0] - xy[a, 0]) * (xy[b, 1] - xy[a, 1])
    faces[area2 < 0] = faces[area2 < 0][:, ::-1]
    faces = faces[np.abs(area2) > 0]
    wse = np.concatenate([np.repeat(n["wse"][:, None], n["fr"].size, axis=1) for n in xs_nodes], axis=1) * to_m
    raw_depth = np.where(np.isfinite(wse), wse - bed[None, :], 0.0)
    speed = np.concatenate([n["speed"] for n in xs_nodes], axis=1) * to_m
    nrm = np.concatenate([np.repeat(n["normal"][None, :], n["fr"].size, axis=0) for n in xs_nodes])
    u, v = speed * nrm[None, :, 0], speed * nrm[None, :, 1]
    times = _parse_profile_times(data.profiles)
    time = times if times is not None else np.arange(nprof)
    crs_wkt = crs or (read_prj(prjs[0]) if prjs else None)
    ds = mesh_snapshot(
        xy[:, 0], xy[:, 1], faces, bed, raw_depth, u, v, time=time, crs_wkt=crs_wkt,
        source="HEC-RAS GIS export (sdf) read by breachflow (reader 'sdf')",
        source_files=[str(p) for p in [*sdfs, *prjs]], check=False,
    )
    if times is None:
        ds["time"].attrs.update(long_name="profile number (steady-flow profiles, not times)", units="1")
        ds["time"].attrs.pop("axis", None)
    ds["profile_name"] = (("time",), np.array(data.profiles, dtype=object), {"long_name": "HEC-RAS profile name"})
    ds["cross_section_station"] = (("node",), np.concatenate([np.full(n["fr"].size, n["xs"].station) for n in xs_nodes]) * to_m,
                                   {"long_name": "HEC-RAS river station of the node's cross section", "units": "m",
                                    "mesh": "mesh2d", "location": "node"})
    ds.attrs.update(
        breachflow_reader="sdf", source_length_unit=unit,
        source_length_unit_from="user" if units else f"UNITS: {data.header.get('UNITS')}",
        interpolation=("nodes on cut lines at surface-line points and velocity fractions; bed linear along the "
                       "cut line; velocity normal to the cut line, downstream; triangles between consecutive "
                       "cross sections of a reach (barycentric in between)"),
    )
    for key in ("MAP PROJECTION", "PROJECTION ZONE", "DATUM", "VERTICAL DATUM"):
        if data.header.get(key):
            ds.attrs[f"source_{key.lower().replace(' ', '_')}"] = data.header[key]
    from ..field.snapshot import validate_snapshot

    validate_snapshot(ds, source=str(data.path))
    return check_plausibility(ds, mode=plausibility, locate=_locator(data, xs_nodes, offsets))


def _locator(data: SdfData, xs_nodes, offsets):
    """``locate(key, index)`` for :func:`check_plausibility`: the line a node's value comes from."""
    def locate(key, idx):
        node = idx.get("node")
        if node is None:
            return None
        s = int(np.searchsorted(offsets, node, side="right")) - 1
        n = xs_nodes[s]
        xs = n["xs"]
        f = n["fr"][node - offsets[s]]
        k = idx.get("time", 0)
        path = str(data.path)
        if key in ("depth", "negative_depth"):
            return path, xs.water_line or xs.line, f"WATER ELEVATION of cross section {xs.station_text}, profile {data.profiles[k]!r}"
        if key == "bed_elevation" and xs.surface_lines:
            sf = _fractions_along(np.asarray(xs.surface, dtype=float)[:, :2])
            return path, xs.surface_lines[int(np.argmin(np.abs(sf - f)))], f"surface line of cross section {xs.station_text}"
        if key == "speed":
            name = data.profiles[k]
            pts, lines = xs.velocities.get(name), xs.velocity_lines.get(name)
            if pts and lines:
                pf = np.array([p[0] for p in pts])
                return path, lines[int(np.argmin(np.abs(pf - f)))], f"VELOCITIES of cross section {xs.station_text}, profile {name!r}"
        return None
    return locate


def _orient_downstream(xs_nodes, data: SdfData) -> None:
    """Flip each section's normal to point downstream (reach centerline, else decreasing station)."""
    reach_lines = {(r.stream, r.reach): np.asarray(r.centerline, dtype=float) for r in data.reaches if len(r.centerline) >= 2}
    for n in xs_nodes:
        xs = n["xs"]
        mid = n["xy"].mean(axis=0)
        cl = reach_lines.get((xs.stream, xs.reach))
        if cl is not None:
            k = int(np.argmin(np.hypot(*(cl[:-1] - mid).T) + np.hypot(*(cl[1:] - mid).T)))
            down = cl[k + 1] - cl[k]
        else:
            others = [m for m in xs_nodes if m is not n and (m["xs"].stream, m["xs"].reach) == (xs.stream, xs.reach)]
            lower = [m for m in others if m["xs"].station < xs.station]
            higher = [m for m in others if m["xs"].station > xs.station]
            if lower:
                tgt = max(lower, key=lambda m: m["xs"].station)
                down = tgt["xy"].mean(axis=0) - mid
            elif higher:
                tgt = min(higher, key=lambda m: m["xs"].station)
                down = mid - tgt["xy"].mean(axis=0)
            else:
                warnings.warn(f"cross section {xs.station_text}: no reach centerline or neighbour to tell downstream; "
                              "velocity direction taken as the cut line's right-hand normal", BreachflowWarning, stacklevel=3)
                continue
        if float(np.dot(n["normal"], down)) < 0:
            n["normal"] = -n["normal"]
