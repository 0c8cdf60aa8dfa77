"""Write a snapshot as a HEC-RAS GIS export (``RASExport.sdf``): 1-D cross sections cut through the field.

A 2-D field has no cross sections of its own, so the writer cuts them: *sections* cut lines given by the
caller (polylines drawn from the left to the right bank looking downstream, listed upstream → downstream),
or by default *n_sections* straight lines across the whole domain, normal to the dominant direction of
the depth-weighted mean velocity, evenly spaced along it. On each cut line *points* equally spaced
points carry (bilinear / barycentric samples of the snapshot, :class:`~breachflow.field.sampling.FieldSampler`):

* ``SURFACE LINE``: x, y, bed elevation;
* ``WATER ELEVATION`` per profile: the median water surface of the wet points (a 1-D section has one
  level; ``NULL`` when the section is dry);
* ``VELOCITIES`` per profile: ``fraction, value`` with value = velocity component along the downstream
  normal of the cut line (what a 1-D model's flow distribution reports; negative = reverse flow).

Profiles are the time steps: ``01JAN2020 0100``-style names when the time axis holds dates, else
``PF 1``, ``PF 2``... (the seconds are listed in a comment line). Stations are distances (file unit) along
the centerline (through the cut-line midpoints) from the most downstream section, increasing upstream as
in HEC-RAS. The reader (``breachflow.io.sdf``) turns the file back into a mesh over the cut
lines; values between sections are then linear interpolations, so the round trip reproduces the field
only on the cut lines.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from ..field.snapshot import DRY_DEPTH, is_mesh, node_coordinates
from .writers import _times, _unit_factor, _write_all


def _extent(ds: xr.Dataset):
    if is_mesh(ds):
        x, y = node_coordinates(ds)
    else:
        x, y = np.asarray(ds["x"].values, float), np.asarray(ds["y"].values, float)
    return float(x.min()), float(x.max()), float(y.min()), float(y.max())


def default_sections(snapshot: xr.Dataset, n_sections: int = 5) -> list[np.ndarray]:
    """*n_sections* straight cut lines across the domain, normal to the mean flow, upstream → downstream."""
    if n_sections < 2:
        raise InputError(f"n_sections={n_sections}: need at least 2 cross sections")
    x0, x1, y0, y1 = _extent(snapshot)
    h = np.asarray(snapshot["depth"].values, float)
    um = float(np.sum(np.asarray(snapshot["u"].values, float) * h))
    vm = float(np.sum(np.asarray(snapshot["v"].values, float) * h))
    pos = (np.arange(n_sections) + 0.5) / n_sections
    out = []
    if abs(um) >= abs(vm):
        xs = x0 + pos * (x1 - x0)
        if um < 0:
            xs = xs[::-1]
        for xv in xs:  # left bank looking downstream: +y when flowing to +x
            out.append(np.array([[xv, y1], [xv, y0]]) if um >= 0 else np.array([[xv, y0], [xv, y1]]))
    else:
        ys = y0 + pos * (y1 - y0)
        if vm < 0:
            ys = ys[::-1]
        for yv in ys:  # flowing to +y the left bank is at -x
            out.append(np.array([[x0, yv], [x1, yv]]) if vm >= 0 else np.array([[x1, yv], [x0, yv]]))
    return out


def _along(line: np.ndarray, fr: np.ndarray) -> np.ndarray:
    seg = np.hypot(*np.diff(line, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = fr * cum[-1]
    return np.column_stack([np.interp(s, cum, line[:, 0]), np.interp(s, cum, line[:, 1])])


def _profile_names(ds: xr.Dataset, secs) -> list[str]:
    if "time" in ds["depth"].dims and np.issubdtype(ds["time"].values.dtype, np.datetime64):
        import pandas as pd

        return [pd.Timestamp(t).strftime("%d%b%Y %H%M").upper() for t in ds["time"].values]
    return [f"PF {k + 1}" for k in range(len(secs))]


def _f(v) -> str:
    return "NULL" if not np.isfinite(v) else f"{v:.6f}"


def sdf_text(snapshot: xr.Dataset, *, sections=None, n_sections: int = 5, points: int = 41, units: str = "m",
             stream: str = "breachflow", reach: str = "export") -> str:
    """The text of :func:`write_sdf`."""
    from ..field.sampling import FieldSampler

    k = _unit_factor(units)
    if points < 3:
        raise InputError(f"points={points}: need at least 3 points per cut line")
    cuts = [np.asarray(s, dtype=float) for s in (sections if sections is not None else default_sections(snapshot, n_sections))]
    for i, c in enumerate(cuts):
        if c.ndim != 2 or c.shape[1] != 2 or c.shape[0] < 2:
            raise InputError(f"section {i}: a cut line is an (m >= 2, 2) array of x, y points")
    secs, _ = _times(snapshot)
    names = _profile_names(snapshot, secs)
    steps = list(range(snapshot.sizes["time"])) if "time" in snapshot["depth"].dims else [None]
    samplers = [FieldSampler(snapshot, "bilinear", time_index=s) for s in steps]
    fr = np.linspace(0.0, 1.0, points)
    mids = np.array([_along(c, np.array([0.5]))[0] for c in cuts])
    dist = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(mids, axis=0).T))])
    station = (dist[-1] - dist) * k
    if len(cuts) > 1 and np.any(np.diff(station) >= 0):
        raise InputError("cross sections must be listed upstream to downstream at distinct places")
    x0, x1, y0, y1 = _extent(snapshot)
    lines = ["# RAS export file written by breachflow (sections cut through a breachflow snapshot)",
             "# profiles: " + ", ".join(f"{n} = t {t:g} s" for n, t in zip(names, secs)), "",
             "BEGIN HEADER:", f"  UNITS: {'METRIC' if abs(k - 1) < 1e-12 else 'US CUSTOMARY'}",
             "  DTM TYPE: GRID", "  NUMBER OF REACHES: 1", f"  NUMBER OF CROSS-SECTIONS: {len(cuts)}",
             "  BEGIN SPATIAL EXTENT:", f"    XMIN: {x0 * k:.6f}", f"    YMIN: {y0 * k:.6f}",
             f"    XMAX: {x1 * k:.6f}", f"    YMAX: {y1 * k:.6f}", "  END SPATIAL EXTENT:",
             f"  NUMBER OF PROFILES: {len(names)}", "  PROFILE NAMES:", *[f"   {n}" for n in names],
             "END HEADER:", "", "BEGIN STREAM NETWORK:",
             f"  ENDPOINT: {mids[0, 0] * k:.6f}, {mids[0, 1] * k:.6f}, NULL, 1",
             f"  ENDPOINT: {mids[-1, 0] * k:.6f}, {mids[-1, 1] * k:.6f}, NULL, 2", "", "  REACH:",
             f"    STREAM ID: {stream}", f"    REACH ID: {reach}", "    FROM POINT: 1", "    TO POINT: 2",
             "    CENTERLINE:", *[f"      {m[0] * k:.6f}, {m[1] * k:.6f}, NULL, {s:.6f}" for m, s in zip(mids, station)],
             "  END:", "", "END STREAM NETWORK:", "", "BEGIN CROSS-SECTIONS:", ""]
    for i, cut in enumerate(cuts):
        p = _along(cut, fr)
        samples = [s.sample(p[:, 0], p[:, 1]) for s in samplers]
        bed = np.where(samples[0].inside, samples[0].bed, np.nan)
        if np.isfinite(bed).sum() < 2:
            raise InputError(f"section {i}: fewer than 2 points of the cut line lie inside the snapshot")
        d = cut[-1] - cut[0]
        normal = np.array([d[1], -d[0]]) / np.hypot(*d)
        down = (mids[min(i + 1, len(cuts) - 1)] - mids[max(i - 1, 0)]) if len(cuts) > 1 else normal
        if float(np.dot(normal, down)) < 0:
            normal = -normal
        wse, vel = [], []
        for s in samples:
            wet = s.inside & (s.depth > DRY_DEPTH)
            wse.append(float(np.median(s.surface[wet])) * k if wet.any() else np.nan)
            vel.append(np.where(s.inside, s.u * normal[0] + s.v * normal[1], 0.0) * k)
        lines += ["  CROSS-SECTION:", f"    STREAM ID: {stream}", f"    REACH ID: {reach}", f"    STATION: {station[i]:.6f}",
                  "    NODE NAME: ", "    BANK POSITIONS: 0.000000, 1.000000",
                  "    REACH LENGTHS: " + ", ".join([f"{(station[i] - station[i + 1]) if i + 1 < len(cuts) else 0.0:.6f}"] * 3),
                  "    CUT LINE:", *[f"      {q[0] * k:.6f}, {q[1] * k:.6f}" for q in cut],
                  "    SURFACE LINE:", *[f"      {q[0] * k:.6f}, {q[1] * k:.6f}, {_f(b * k)}" for q, b in zip(p, bed)],
                  "    WATER ELEVATION: " + ", ".join(_f(w) for w in wse)]
        for name, vv in zip(names, vel):
            lines += [f"    PROFILE ID: {name}", "    VELOCITIES:", *[f"      {f:.6f}, {val:.6f}" for f, val in zip(fr, vv)]]
        lines += ["  END:", ""]
    lines += ["END CROSS-SECTIONS:", ""]
    return "\n".join(lines)


def write_sdf(snapshot: xr.Dataset, path, *, sections=None, n_sections: int = 5, points: int = 41,
              units: str = "m", stream: str = "breachflow", reach: str = "export") -> Path:
    """Write *snapshot* (grid or mesh) as a HEC-RAS ``RASExport.sdf`` with cross sections cut through it
    (see the module doc); returns the path. Read back with ``open_snapshot(path)``."""
    path = Path(path)
    _write_all({path: sdf_text(snapshot, sections=sections, n_sections=n_sections, points=points, units=units,
                               stream=stream, reach=reach)})
    return path
