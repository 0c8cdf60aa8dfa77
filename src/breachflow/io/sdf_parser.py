"""Parser of the HEC-RAS GIS export text format (``RASExport.sdf``): :func:`read_sdf` → :class:`SdfData`
(header, profile names, reaches, cross sections with the file line of every value); ``sdf.open_sdf``
turns it into a mesh snapshot.

Grammar (HEC-RAS user manual, RASImport/RASExport spatial data format; parsers in ANUGA ``sdf2pts.py``
and HABBY): ``BEGIN HEADER:``/``END HEADER:`` (``UNITS: US CUSTOMARY | METRIC``, ``PROFILE NAMES:`` then
one name per line...), ``BEGIN STREAM NETWORK:`` (``ENDPOINT:``, ``REACH:`` ... ``CENTERLINE:`` points
``END:``), ``BEGIN CROSS-SECTIONS:`` (``CROSS-SECTION:`` ... ``END:`` with ``CUT LINE:``, ``SURFACE LINE:``,
``WATER ELEVATION:`` one value per profile, ``PROFILE ID:`` + ``VELOCITIES:`` lines ``fraction, value``),
``WATER SURFACE EXTENTS:`` lines ``x_left, y_left, x_right, y_right`` (kept, not used),
``BEGIN STORAGE AREAS:`` and ``BEGIN BOUNDS:`` (skipped). A keyword is the text before the *first* colon
and must match a known keyword exactly (no substring matching; inner spaces optional, as in
``BEGINSTREAMNETWORK:`` / ``BEGIN SPATIALEXTENT:`` of some HEC-RAS versions); an unknown keyword is
warned about with its line (an error with ``strict=True``) and its value lines are skipped; ``NULL`` marks an unknown value;
stations may carry a ``*`` (interpolated section).
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, ParseError
from ._text import LineReader, as_text

KEYWORDS = {
    "BEGIN HEADER", "END HEADER", "UNITS", "DTM TYPE", "DTM", "STREAM LAYER", "NUMBER OF REACHES",
    "CROSS-SECTION LAYER", "NUMBER OF CROSS-SECTIONS", "MAP PROJECTION", "PROJECTION ZONE", "DATUM",
    "VERTICAL DATUM", "BEGIN SPATIAL EXTENT", "END SPATIAL EXTENT", "XMIN", "YMIN", "XMAX", "YMAX",
    "NUMBER OF PROFILES", "PROFILE NAMES", "BEGIN STREAM NETWORK", "END STREAM NETWORK", "ENDPOINT",
    "REACH", "STREAM ID", "REACH ID", "FROM POINT", "TO POINT", "CENTERLINE", "END", "BEGIN CROSS-SECTIONS",
    "END CROSS-SECTIONS", "CROSS-SECTION", "STATION", "NODE NAME", "BANK POSITIONS", "REACH LENGTHS",
    "CUT LINE", "SURFACE LINE", "WATER ELEVATION", "PROFILE ID", "VELOCITIES", "BEGIN STORAGE AREAS",
    "END STORAGE AREAS", "STORAGE AREA", "SA ID", "SURFACE", "BEGIN BOUNDS", "END BOUNDS", "PROFILE LIMITS",
    "POLYGON", "LEFT BANK", "RIGHT BANK", "LEVEE POSITIONS", "INEFFECTIVE POSITIONS", "BLOCKED POSITIONS",
    "MANNINGS N", "ROUGHNESS", "BRIDGE", "CULVERT", "INLINE STRUCTURE", "LATERAL STRUCTURE",
    "BEGIN STREAM NETWORK", "BEGIN LATERAL STRUCTURES", "END LATERAL STRUCTURES", "BEGIN INLINE STRUCTURES",
    "END INLINE STRUCTURES", "NUMBER OF STORAGE AREAS", "BEGIN BREAKLINES", "END BREAKLINES",
    "WATER SURFACE EXTENTS",
}
#: keywords written without their inner spaces by some HEC-RAS versions (``BEGINSTREAMNETWORK:``,
#: ``BEGIN SPATIALEXTENT:``) map to the spelled-out keyword
_NOSPACE = {k.replace(" ", ""): k for k in KEYWORDS}
_KEYLIKE = re.compile(r"[A-Z][A-Z0-9 _/()\-]*")
_HEADER_ONLY = {"UNITS", "DTM TYPE", "DTM", "STREAM LAYER", "NUMBER OF REACHES", "CROSS-SECTION LAYER",
                "NUMBER OF CROSS-SECTIONS", "MAP PROJECTION", "PROJECTION ZONE", "DATUM", "VERTICAL DATUM",
                "NUMBER OF PROFILES", "XMIN", "YMIN", "XMAX", "YMAX"}
_SKIP_BLOCKS = {"BEGIN STORAGE AREAS": "END STORAGE AREAS", "BEGIN BOUNDS": "END BOUNDS",
                "BEGIN LATERAL STRUCTURES": "END LATERAL STRUCTURES", "BEGIN INLINE STRUCTURES": "END INLINE STRUCTURES",
                "BEGIN BREAKLINES": "END BREAKLINES"}


@dataclass
class CrossSection:
    line: int
    stream: str = ""
    reach: str = ""
    station: float | None = None
    station_text: str = ""
    cut: list = field(default_factory=list)          # [(x, y)]
    surface: list = field(default_factory=list)      # [(x, y, z or nan)]
    water: list = field(default_factory=list)        # per profile (nan = NULL)
    water_line: int = 0
    extents: list = field(default_factory=list)      # WATER SURFACE EXTENTS: (x_left, y_left, x_right, y_right) per profile
    velocities: dict = field(default_factory=dict)   # profile name -> [(fraction, value)]
    surface_lines: list = field(default_factory=list)  # file line of each surface point
    velocity_lines: dict = field(default_factory=dict)  # profile name -> [file line of each velocity point]


@dataclass
class Reach:
    stream: str = ""
    reach: str = ""
    centerline: list = field(default_factory=list)   # [(x, y)]


@dataclass
class SdfData:
    path: Path
    header: dict
    profiles: list
    reaches: list
    sections: list


def _split(text: str):
    """``(KEYWORD, value)`` when the text before the first colon is a known keyword (spaces inside it
    optional), ``("?" + key, value)`` for an unknown keyword-like key, else None."""
    if ":" not in text:
        return None
    key, value = text.split(":", 1)
    key = re.sub(r"\s+", " ", key.strip().upper())
    if key in KEYWORDS:
        return key, value.strip()
    if key.replace(" ", "") in _NOSPACE:
        return _NOSPACE[key.replace(" ", "")], value.strip()
    if _KEYLIKE.fullmatch(key) and not re.search(r"\d", key):
        return "?" + key, value.strip()
    return None


def _numbers(text: str, n_min: int, n_max: int, path, line, what: str, allow_null=False):
    toks = [t.strip() for t in re.split(r"[,\s]+", text.strip()) if t.strip()]
    if not n_min <= len(toks) <= n_max:
        raise ParseError(f"{what}: expected {n_min}{'' if n_min == n_max else f'-{n_max}'} values, found {len(toks)} "
                         f"({text.strip()[:60]!r})", path=path, line=line)
    out = []
    for t in toks:
        if t.upper() == "NULL" and allow_null:
            out.append(np.nan)
            continue
        try:
            v = float(t)
        except ValueError:
            raise ParseError(f"{what}: non-numeric value {t[:30]!r}", path=path, line=line) from None
        if not np.isfinite(v):
            raise ParseError(f"{what}: value {t!r} is not finite", path=path, line=line)
        out.append(v)
    return out


def read_sdf(path, *, strict: bool = False) -> SdfData:
    """Parse a HEC-RAS ``.sdf`` GIS export (see module doc); ParseError names the line of bad input."""
    path = Path(path)
    header: dict[str, str] = {}
    profiles: list[str] = []
    reaches: list[Reach] = []
    sections: list[CrossSection] = []
    block = None          # HEADER, NETWORK, XS, or a skip end keyword
    list_mode = None      # PROFILE NAMES, CENTERLINE, CUT LINE, SURFACE LINE, VELOCITIES
    cur_xs: CrossSection | None = None
    cur_reach: Reach | None = None
    cur_profile = None
    seen_header = False
    unknown: dict[str, int] = {}
    with LineReader(path) as rd:
        while True:
            raw = rd.readline()
            if raw is None:
                break
            ln = rd.line_no
            text = as_text(raw, path, ln).strip()
            if not text or text.startswith("#"):
                continue
            kv = _split(text)
            if kv is not None and kv[0].startswith("?") and list_mode == "PROFILE NAMES":
                kv = None  # a profile name with a colon
            if block in _SKIP_BLOCKS.values():
                if kv and kv[0] == block:
                    block = None
                continue
            if kv is not None and kv[0].startswith("?"):
                if strict:
                    raise ParseError(f"unknown keyword {kv[0][1:][:40]!r} (strict mode)", path=path, line=ln)
                unknown.setdefault(kv[0][1:], ln)
                list_mode = None  # its value lines (if any) are skipped, not read as the previous list
                continue
            if kv is None:
                if list_mode == "PROFILE NAMES":
                    profiles.append(text)
                elif list_mode == "CENTERLINE":
                    vals = _numbers(text, 2, 4, path, ln, "centerline point", allow_null=True)
                    cur_reach.centerline.append((vals[0], vals[1]))
                elif list_mode == "CUT LINE":
                    cur_xs.cut.append(tuple(_numbers(text, 2, 2, path, ln, "cut-line point")))
                elif list_mode == "SURFACE LINE":
                    cur_xs.surface.append(tuple(_numbers(text, 3, 3, path, ln, "surface-line point (x, y, z)", allow_null=True)))
                    cur_xs.surface_lines.append(ln)
                elif list_mode == "WATER SURFACE EXTENTS":
                    cur_xs.extents.append(tuple(_numbers(text, 4, 4, path, ln, "water surface extent (x, y, x, y)", allow_null=True)))
                elif list_mode == "VELOCITIES":
                    f, v = _numbers(text, 2, 2, path, ln, "velocity point (fraction, value)")
                    if not -1e-9 <= f <= 1 + 1e-9:
                        raise ParseError(f"velocity position {f:g} is not a fraction of the cut line (0..1)", path=path, line=ln)
                    cur_xs.velocities[cur_profile].append((f, v))
                    cur_xs.velocity_lines.setdefault(cur_profile, []).append(ln)
                else:
                    if strict or block in (None,):
                        raise ParseError(f"unexpected line {text[:60]!r}", path=path, line=ln)
                continue
            key, value = kv
            list_mode = None
            if key == "BEGIN HEADER":
                block, seen_header = "HEADER", True
            elif key == "END HEADER":
                _expect(block, "HEADER", key, path, ln)
                block = None
            elif key in ("BEGIN STREAM NETWORK", "BEGIN CROSS-SECTIONS"):
                if block is not None:
                    raise ParseError(f"{key} inside another block (missing END?)", path=path, line=ln)
                block = "NETWORK" if "STREAM" in key else "XS"
            elif key in ("END STREAM NETWORK", "END CROSS-SECTIONS"):
                _expect(block, "NETWORK" if "STREAM" in key else "XS", key, path, ln)
                if cur_xs is not None or cur_reach is not None:
                    raise ParseError(f"{key} before the END: of the open {'CROSS-SECTION' if cur_xs else 'REACH'}", path=path, line=ln)
                block = None
            elif key in _SKIP_BLOCKS:
                block = _SKIP_BLOCKS[key]
            elif key == "PROFILE NAMES":
                _expect(block, "HEADER", key, path, ln)
                list_mode = key
            elif block == "HEADER":
                header[key] = value
            elif key in _HEADER_ONLY and strict:
                raise ParseError(f"{key} outside its block (header keyword)", path=path, line=ln)
            elif key == "REACH":
                _expect(block, "NETWORK", key, path, ln)
                cur_reach = Reach()
            elif key == "CROSS-SECTION":
                _expect(block, "XS", key, path, ln)
                if cur_xs is not None:
                    raise ParseError(f"CROSS-SECTION before the END: of the one at line {cur_xs.line}", path=path, line=ln)
                cur_xs = CrossSection(line=ln)
            elif key == "END":
                if cur_xs is not None:
                    sections.append(cur_xs)
                    cur_xs = None
                elif cur_reach is not None:
                    reaches.append(cur_reach)
                    cur_reach = None
            elif key in ("STREAM ID", "REACH ID"):
                target = cur_xs or cur_reach
                if target is not None:
                    setattr(target, "stream" if key == "STREAM ID" else "reach", value)
            elif key == "CENTERLINE":
                if cur_reach is None:
                    raise ParseError("CENTERLINE outside a REACH", path=path, line=ln)
                list_mode = key
            elif cur_xs is not None and key == "STATION":
                cur_xs.station_text = value
                try:
                    cur_xs.station = float(value.rstrip("*").strip())
                except ValueError:
                    raise ParseError(f"river station {value[:30]!r} is not a number", path=path, line=ln) from None
            elif cur_xs is not None and key in ("CUT LINE", "SURFACE LINE", "WATER SURFACE EXTENTS"):
                list_mode = key
                if key == "WATER SURFACE EXTENTS" and value:  # the four numbers on the keyword line
                    cur_xs.extents.append(tuple(_numbers(value, 4, 4, path, ln, "water surface extent (x, y, x, y)", allow_null=True)))
            elif cur_xs is not None and key == "WATER ELEVATION":
                cur_xs.water = _numbers(value, 1, 10**6, path, ln, "WATER ELEVATION", allow_null=True)
                cur_xs.water_line = ln
            elif cur_xs is not None and key == "PROFILE ID":
                cur_profile = value
                if cur_profile in cur_xs.velocities:
                    raise ParseError(f"profile {value!r} listed twice in this cross section", path=path, line=ln)
                cur_xs.velocities[cur_profile] = []
            elif cur_xs is not None and key == "VELOCITIES":
                if cur_profile is None or cur_profile not in cur_xs.velocities:
                    raise ParseError("VELOCITIES without a preceding PROFILE ID", path=path, line=ln)
                list_mode = key
            # other known keywords carry information we do not need
        if block is not None or cur_xs is not None:
            raise ParseError("file ends inside a block (missing END:)", path=path, line=rd.line_no)
    if not seen_header:
        raise ParseError("no BEGIN HEADER: block (not a HEC-RAS GIS export?)", path=path, line=1)
    if unknown:
        warnings.warn(f"{path}: ignored unknown keyword(s) " + ", ".join(f"{k!r} (line {n})" for k, n in unknown.items()),
                      BreachflowWarning, stacklevel=2)
    n_prof = header.get("NUMBER OF PROFILES")
    if n_prof is not None:
        try:
            n = int(n_prof)
        except ValueError:
            raise ParseError(f"NUMBER OF PROFILES {n_prof!r} is not an integer", path=path) from None
        if profiles and n != len(profiles):
            raise ParseError(f"NUMBER OF PROFILES is {n} but {len(profiles)} names are listed", path=path)
        if not profiles:
            profiles = [f"PF {k + 1}" for k in range(n)]
    for xs in sections:
        if len(xs.water) != len(profiles):
            raise ParseError(f"cross section {xs.station_text or '?'}: {len(xs.water)} water elevations for "
                             f"{len(profiles)} profiles", path=path, line=xs.water_line or xs.line)
        if len(xs.cut) < 2:
            raise ParseError(f"cross section {xs.station_text or '?'}: cut line needs at least 2 points", path=path, line=xs.line)
        if xs.station is None:
            raise ParseError("cross section without STATION", path=path, line=xs.line)
        for name in xs.velocities:
            if name not in profiles:
                raise ParseError(f"cross section {xs.station_text}: velocities for unknown profile {name!r}", path=path, line=xs.line)
    return SdfData(path, header, profiles, reaches, sections)


def _expect(block, want, key, path, line):
    if block != want:
        raise ParseError(f"{key} outside its block", path=path, line=line)
