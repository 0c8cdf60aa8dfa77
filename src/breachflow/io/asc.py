"""ESRI ASCII grids (``.asc``), e.g. HEC-RAS RAS Mapper maps converted to text with GDAL.

Header (keywords case-insensitive, GDAL AAIGrid): ``ncols``, ``nrows``, ``xllcorner|xllcenter``,
``yllcorner|yllcenter``, ``cellsize`` (or ``dx`` and ``dy``), optional ``NODATA_value``; then
``nrows × ncols`` numbers as a flat stream, the first row being the northern one. A ``.prj`` beside the
file (same stem) gives the CRS.

Several grids on the same geometry form one snapshot; each file's role comes from ``roles=`` or from
its name: ``depth``/``dep``; ``wse``/``water surface``/``stage``; ``terrain``/``bed``/``dem``/``elev``;
``vx``/``velocity_x`` and ``vy``/``velocity_y``; ``velocity``/``vel``/``speed`` (magnitude only: needs
``velocity_direction=`` in degrees anticlockwise from +x, since a map of speed has no direction).

Files may have any extension when the format (``format="asc"``) or their role (``roles=``) is given;
LISFLOOD-FP's ``.wd``, ``.elev``, ``.Vx``, ``.Vy``, ``.dem`` tell their role by the extension. ``NODATA_value
nan`` and NaN cells (``nan``, ``-nan``, ``1.#QNAN`` as GDAL / MSVC write them) are NODATA; ``inf`` is an error.

NODATA handling: depth / velocity NODATA cells are dry (0); a water-surface NODATA cell is dry; terrain
NODATA is an error (the snapshot grid must have a bed everywhere). Without a terrain grid the bed is
``wse − depth`` (where both are known) or the ``bed=`` option.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, InputError, ParseError
from ._text import LineReader, as_text, parse_floats, to_float, to_int


@dataclass
class AscGrid:
    path: Path
    ncols: int
    nrows: int
    x0: float  #: centre of the lower-left cell (file units)
    y0: float
    dx: float
    dy: float
    nodata: float | None
    values: np.ndarray  #: (nrows, ncols), first row = southern after flipping; NaN at NODATA
    first_data_line: int = 0  #: 1-based line of the first grid value

    def value_line(self, row: int, col: int) -> int:
        """File line of the value in *row*, *col* (1-based, rows counted from the top as in the file).

        The values are a flat stream (GDAL): the line is found by counting tokens (used for error messages).
        """
        k = (row - 1) * self.ncols + (col - 1)
        with LineReader(self.path) as rd:
            while rd.line_no < self.first_data_line - 1:
                rd.readline()
            while True:
                raw = rd.readline()
                if raw is None:
                    return rd.line_no
                n = len(raw.split())
                if k < n:
                    return rd.line_no
                k -= n

    def geometry(self):
        return (self.ncols, self.nrows, self.x0, self.y0, self.dx, self.dy)


_HEADER_KEYS = {"ncols", "nrows", "xllcorner", "xllcenter", "yllcorner", "yllcenter", "cellsize", "dx", "dy",
                "nodata_value", "nbits", "byteorder", "layout"}


def read_asc(path) -> AscGrid:
    """Parse one ESRI ASCII grid; rows are returned south → north (ascending y), NODATA as NaN."""
    path = Path(path)
    head: dict[str, tuple[str, int]] = {}
    with LineReader(path) as rd:
        while True:
            raw = rd.peek_line()
            if raw is None:
                raise ParseError("file ends in the header (no grid values)", path=path, line=rd.line_no + 1)
            text = as_text(raw, path, rd.line_no + 1).strip()
            if not text:
                rd.readline()
                continue
            toks = text.split()
            if not re.match(r"[A-Za-z_]", toks[0]) or toks[0].lower() in _NAN_TOKENS:
                break
            rd.readline()
            key = toks[0].lower()
            if key not in _HEADER_KEYS:
                raise ParseError(f"unknown header keyword {toks[0][:30]!r}", path=path, line=rd.line_no)
            if len(toks) != 2:
                raise ParseError(f"header line {key} needs exactly one value", path=path, line=rd.line_no)
            if key in head:
                raise ParseError(f"header keyword {key} given twice", path=path, line=rd.line_no)
            head[key] = (toks[1], rd.line_no)
        first_data_line = rd.line_no + 1

        def num(key, integer=False):
            tok, line = head[key]
            return (to_int if integer else to_float)(tok, path=path, line=line, what=f"header {key}")

        for key in ("ncols", "nrows"):
            if key not in head:
                raise ParseError(f"header lacks {key}", path=path, line=first_data_line)
        ncols, nrows = num("ncols", True), num("nrows", True)
        if ncols < 1 or nrows < 1:
            raise ParseError(f"grid size {ncols} x {nrows} must be positive", path=path, line=head["ncols"][1])
        if "cellsize" in head:
            dx = dy = num("cellsize")
        elif "dx" in head and "dy" in head:
            dx, dy = num("dx"), num("dy")
        else:
            raise ParseError("header lacks cellsize (or dx and dy)", path=path, line=first_data_line)
        if dx <= 0 or dy <= 0:
            raise ParseError(f"cell size {dx:g} x {dy:g} must be positive", path=path, line=first_data_line - 1)
        xs = [k for k in ("xllcorner", "xllcenter") if k in head]
        ys = [k for k in ("yllcorner", "yllcenter") if k in head]
        if len(xs) != 1 or len(ys) != 1:
            raise ParseError("header needs one of xllcorner/xllcenter and one of yllcorner/yllcenter",
                             path=path, line=first_data_line)
        x0 = num(xs[0]) + (dx / 2 if xs[0] == "xllcorner" else 0.0)
        y0 = num(ys[0]) + (dy / 2 if ys[0] == "yllcorner" else 0.0)
        nodata = None
        if "nodata_value" in head:
            tok, line = head["nodata_value"]
            nodata = float("nan") if tok.strip().lower() in _NAN_TOKENS else num("nodata_value")
        rest = []
        while True:
            block, _ = rd.read_chunk()
            if not block:
                break
            rest.append(block)
    data = b"".join(rest)
    n = nrows * ncols
    most = (len(data) + 1) // 2  # every value takes a character and a separator
    if n > most:  # checked before anything of that size is allocated
        raise ParseError(f"header ncols {ncols:,} × nrows {nrows:,} = {n:,} values, but the file holds only "
                         f"{len(data):,} bytes of values (at most {most:,} values); wrong ncols/nrows?",
                         path=path, line=head["ncols"][1])
    vals = parse_floats(data)
    if vals is None or vals.size != n or np.isinf(vals).any():
        vals = _slow_values(data, n, path, first_data_line)
    grid = vals.reshape(nrows, ncols)[::-1].copy()
    if nodata is not None and np.isfinite(nodata):
        grid[grid == nodata] = np.nan  # NaN cells (GDAL writes "nan") are NODATA as well
    return AscGrid(path, ncols, nrows, x0, y0, dx, dy, nodata, grid, first_data_line)


_NAN_TOKENS = {"nan", "-nan", "+nan", "1.#qnan", "-1.#qnan", "-1.#ind", "1.#ind", "nan(ind)", "-nan(ind)"}


def _slow_values(data: bytes, n: int, path, first_line: int) -> np.ndarray:
    """Token by token: NaN spellings (GDAL, MSVC) are NODATA cells; the line of a bad token is named."""
    out = np.empty(n)
    count = 0
    for i, raw in enumerate(data.split(b"\n")):
        for tok in raw.split():
            text = as_text(tok, path, 0)
            if text.lower() in _NAN_TOKENS:
                v = np.nan
            else:
                try:
                    v = float(tok)
                except ValueError:
                    raise ParseError(f"non-numeric grid value {text[:30]!r}", path=path, line=first_line + i) from None
                if not np.isfinite(v):
                    raise ParseError(f"grid value {text!r} is not finite (use NODATA_value)", path=path, line=first_line + i)
            if count >= n:
                raise ParseError(f"more than nrows x ncols = {n} values", path=path, line=first_line + i)
            out[count] = v
            count += 1
    if count != n:
        raise ParseError(f"expected nrows x ncols = {n} values, found {count}", path=path, line=first_line + max(data.count(b"\n") - 1, 0))
    return out


_ROLES = (
    ("u", re.compile(r"(^|[^a-z])(vx|velocity_?x|vel_?x|u)([^a-z]|$)", re.I)),
    ("v", re.compile(r"(^|[^a-z])(vy|velocity_?y|vel_?y|v)([^a-z]|$)", re.I)),
    ("water_surface", re.compile(r"wse|water.?surface|stage|wsel", re.I)),
    ("depth", re.compile(r"depth|(^|[^a-z])dep([^a-z]|$)", re.I)),
    ("bed", re.compile(r"terrain|bed|dem|elev|ground", re.I)),
    ("speed", re.compile(r"velocity|vel|speed", re.I)),
)


#: LISFLOOD-FP result grids are ESRI ASCII grids whose extension tells the quantity (LISFLOOD-FP manual:
#: .wd water depth, .elev water-surface elevation, .Vx/.Vy velocity components, .dem terrain)
SUFFIX_ROLES = {".wd": "depth", ".elev": "water_surface", ".vx": "u", ".vy": "v", ".dem": "bed", ".dep": "depth",
                ".wse": "water_surface"}


def grid_role(path: Path) -> str | None:
    if path.suffix.lower() in SUFFIX_ROLES:
        return SUFFIX_ROLES[path.suffix.lower()]
    for role, pat in _ROLES:
        if pat.search(path.stem):
            return role
    return None


def prj_length_unit(wkt: str) -> str | None:
    """Linear unit of a projected WKT1 CRS (the last top-level UNIT of PROJCS), as a pint unit name."""
    m = re.findall(r'UNIT\["([^"]+)",\s*([0-9.eE+-]+)', wkt)
    if wkt.upper().startswith("PROJCS") and m:
        try:
            f = float(m[-1][1])
        except ValueError:
            return None
    else:  # WKT2, EPSG:nnnn, PROJ strings: ask pyproj
        from ..field.crs import crs_length_unit
        from pyproj import CRS

        try:
            unit = crs_length_unit(CRS.from_user_input(wkt))
        except Exception:
            return None
        if unit is None:
            return None
        f = unit[1]
    if abs(f - 1.0) < 1e-12:
        return "m"
    if abs(f - 0.3048006096012192) < 1e-12:
        return "survey_foot"
    if abs(f - 0.3048) < 1e-12:
        return "ft"
    return None


def open_asc(paths, *, units=None, crs=None, plausibility="raise", roles=None, bed=None,
             velocity_direction=None, **unused):
    """ESRI ASCII grids → grid snapshot (SI). See the module doc for roles and NODATA handling."""
    from ..units import to_si, ureg
    from ..field.snapshot import check_plausibility, grid_snapshot
    from . import read_prj, unknown_options

    unknown_options("asc", unused)
    paths = [Path(p) for p in paths]
    prjs = [p for p in paths if p.suffix.lower() == ".prj"]
    grids_p = [p for p in paths if p.suffix.lower() != ".prj"]  # .asc, or any extension (.wd, .txt, ...)
    if not grids_p:
        raise InputError("asc reader: no grid file given")
    roles = {Path(k).name: v for k, v in (roles or {}).items()}
    by_role: dict[str, AscGrid] = {}
    for p in grids_p:
        role = roles.get(p.name) or grid_role(p)
        if role not in ("depth", "water_surface", "bed", "u", "v", "speed"):
            raise InputError(f"{p}: cannot tell what the grid holds from its name; pass roles={{'{p.name}': "
                             f"'depth' | 'water_surface' | 'bed' | 'u' | 'v' | 'speed'}}")
        if role in by_role:
            raise InputError(f"two grids for {role}: {by_role[role].path.name} and {p.name}")
        by_role[role] = read_asc(p)
    ref = next(iter(by_role.values()))
    for g in by_role.values():
        if not np.allclose(g.geometry(), ref.geometry(), rtol=1e-9, atol=1e-6 * ref.dx):
            raise InputError(f"grids {ref.path.name} and {g.path.name} differ in size, origin or cell size; "
                             "resample them onto one grid first")
    if crs is None:
        side = [p.with_suffix(".prj") for p in grids_p if p.with_suffix(".prj").exists()]
        prj_files = prjs or side[:1]
        crs = read_prj(prj_files[0]) if prj_files else None
    unit = units
    unit_from = "user"
    if unit is None and crs is not None:
        unit = prj_length_unit(crs)
        unit_from = "the .prj linear unit"
    if unit is None:
        raise InputError("ESRI ASCII grids carry no units: pass units='m' or units='ft' (or a projected .prj)")
    try:
        to_m = float(ureg.Quantity(1.0, str(unit)).to("m").magnitude)
    except Exception:
        raise InputError(f"units={unit!r}: not a length unit (use 'm' or 'ft')") from None

    shape = ref.values.shape
    depth_g = by_role.get("depth")
    wse_g = by_role.get("water_surface")
    bed_g = by_role.get("bed")
    terrain_only = depth_g is None and wse_g is None
    if terrain_only and by_role.get("bed") is None:
        raise InputError("asc reader: need a depth, water-surface or terrain grid")
    if bed_g is not None:
        if np.isnan(bed_g.values).any():
            top = np.argwhere(np.isnan(bed_g.values[::-1]))[0]  # first in file order
            row, col = int(top[0]) + 1, int(top[1]) + 1
            raise InputError(f"{bed_g.path}:{bed_g.value_line(row, col)}: terrain has NODATA at row {row}, column {col} "
                             "(from the top, 1-based); crop the grids to the terrain")
        bed_v = bed_g.values * to_m
    elif bed is not None:
        bed_v = np.broadcast_to(to_si(bed, name="bed", kind="length"), shape).astype(float)
    elif depth_g is not None and wse_g is not None and not (np.isnan(depth_g.values) | np.isnan(wse_g.values)).any():
        bed_v = (wse_g.values - depth_g.values) * to_m
    else:
        raise InputError("asc reader: the bed elevation is unknown; give a terrain grid, both depth and "
                         "water-surface grids without NODATA, or bed='<elevation with unit>'")
    if terrain_only:  # a terrain grid alone: depth 0, velocity 0
        raw_depth = np.zeros(shape)
    elif depth_g is not None:
        raw_depth = depth_g.values * to_m
    else:
        raw_depth = wse_g.values * to_m - bed_v
    depth = np.where(np.isnan(raw_depth), 0.0, raw_depth)
    if "u" in by_role or "v" in by_role:
        if not ("u" in by_role and "v" in by_role):
            raise InputError("asc reader: velocity components need both a vx and a vy grid")
        u = np.nan_to_num(by_role["u"].values) * to_m
        v = np.nan_to_num(by_role["v"].values) * to_m
    elif "speed" in by_role:
        if velocity_direction is None:
            raise InputError(f"{by_role['speed'].path.name} holds speeds without direction; pass "
                             "velocity_direction=<degrees anticlockwise from +x> or vx/vy grids")
        ang = np.deg2rad(to_si(velocity_direction, name="velocity_direction", kind="dimensionless")
                         if not isinstance(velocity_direction, str) else
                         ureg.Quantity(velocity_direction).to("degree").magnitude)
        sp = np.nan_to_num(by_role["speed"].values) * to_m
        u, v = sp * np.cos(ang), sp * np.sin(ang)
    else:
        if not terrain_only:
            warnings.warn("no velocity grid: velocity set to zero", BreachflowWarning, stacklevel=2)
        u = v = np.zeros(shape)
    x = (ref.x0 + ref.dx * np.arange(ref.ncols)) * to_m
    y = (ref.y0 + ref.dy * np.arange(ref.nrows)) * to_m
    files = [g.path for g in by_role.values()] + prjs
    ds = grid_snapshot(x, y, bed_v, depth, u, v, crs_wkt=crs, source="ESRI ASCII grids read by breachflow (reader 'asc')",
                       source_files=[str(p) for p in files])
    ds.attrs.update(breachflow_reader="asc", source_length_unit=str(unit), source_length_unit_from=unit_from,
                    source_grids="; ".join(f"{r}: {g.path.name}" for r, g in by_role.items()))
    if terrain_only:
        ds.attrs["breachflow_content"] = "terrain: a grid without results (depth 0, velocity 0)"
    return check_plausibility(ds, mode=plausibility, raw_depth=np.nan_to_num(raw_depth), locate=_locator(by_role, bed_g is None and bed is not None))


def _locator(by_role: dict, bed_from_user: bool):
    """``locate(key, index)`` for :func:`check_plausibility`: file, line, row and column from the top."""
    def locate(key, idx):
        if "y" not in idx or "x" not in idx:
            return None
        j, i = idx["y"], idx["x"]
        if key in ("depth", "negative_depth"):
            g = by_role.get("depth") or by_role.get("water_surface")
        elif key == "bed_elevation":  # a terrain grid, or bed = wse - depth; no file when bed= was given
            g = None if bed_from_user else by_role.get("bed") or by_role.get("water_surface")
        else:
            g = by_role.get("speed")
            if "u" in by_role and "v" in by_role:
                g = max((by_role["u"], by_role["v"]), key=lambda a: abs(np.nan_to_num(a.values[j, i])))
        if g is None:
            return None
        row, col = g.nrows - j, i + 1
        return str(g.path), g.value_line(row, col), f"row {row}, column {col} (from the top, 1-based) of {g.path.name}"
    return locate
