#!/usr/bin/env python3
"""Check breachflow NetCDF files with the CF checker (cfchecker) and GDAL, offline.

    python3 tools/cf_check.py FILE.nc [FILE.nc ...]
    python3 tools/cf_check.py --setup        # only create the checker environment (``tasks.py test`` does)

Sets up ``.venv-cfcheck`` once (cfchecker, and compliance-checker only for the CF standard-name table it
ships, so nothing is fetched from the web). cfchecker also wants the CF area-type and region-name tables;
breachflow files use neither (no ``where`` cell methods, no region variables), so empty tables are passed.
cfchecker needs the UDUNITS-2 library (Debian: ``apt-get install libudunits2-0``); the GDAL check runs
when ``gdalinfo`` is on PATH (Debian: ``gdal-bin``) and prints each grid's CRS and geotransform.
cfchecker (4.1.0, the newest release) knows only the cf_role values of CF §9.5 (discrete sampling
geometries); UGRID-1.0 mesh files (``Conventions = "CF-1.8 UGRID-1.0"``; UGRID is part of CF from 1.11)
get its "(9.5) Invalid value for cf_role" for their ``mesh_topology`` / ``*_connectivity`` variables.
For those variables only, that error is replaced by a check of the UGRID-1.0 rules themselves
(:func:`ugrid_problems`: required attributes, referenced variables, connectivity indices in range).
Exits non-zero when cfchecker reports an error or a warning, or when a file requests a CRS (a
``grid_mapping`` with ``crs_wkt``) that pyproj cannot read or GDAL does not report. The test suite uses
the same functions
(``tests/output/test_cf_gis_check.py``).
"""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import venv
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VENV = ROOT / ".venv-cfcheck"
BIN = VENV / "bin"
STAMP = VENV / ".cfcheck-installed"
PACKAGES = ("cfchecker", "compliance-checker")
EMPTY = """<?xml version="1.0"?>
<{tag}>
  <version_number>0</version_number>
  <date>2026-01-01</date>
  <last_modified>2026-01-01T00:00:00Z</last_modified>
</{tag}>
"""


def ensure_env(install: bool = True) -> Path | None:
    """The CF standard-name table of the checker environment (created when *install*); None if absent."""
    if not STAMP.exists():
        if not install:
            return None
        venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
        subprocess.run([str(BIN / "pip"), "install", "-q", "--disable-pip-version-check", *PACKAGES], check=True)
        out = subprocess.run([str(BIN / "python"), "-c",
                              "import compliance_checker, os; print(os.path.dirname(compliance_checker.__file__))"],
                             check=True, capture_output=True, text=True).stdout.strip()
        STAMP.write_text(str(Path(out) / "data" / "cf-standard-name-table.xml"))
    return Path(STAMP.read_text().strip())


@dataclass
class CfReport:
    errors: int  # -1: cfchecker did not report (it failed to run)
    warnings: int
    messages: list = field(default_factory=list)
    output: str = ""


UGRID_ROLES = ("mesh_topology", "face_node_connectivity", "edge_node_connectivity", "face_edge_connectivity",
               "face_face_connectivity", "edge_face_connectivity", "boundary_node_connectivity")

UGRID_SCRIPT = r"""
import json, sys
import netCDF4, numpy as np
roles = set(sys.argv[2].split(","))
d = netCDF4.Dataset(sys.argv[1])
d.set_auto_mask(False)
out = {"ugrid": "UGRID" in str(getattr(d, "Conventions", "")), "roles": {}, "problems": []}
v = d.variables
def bad(msg): out["problems"].append(msg)
for name, var in v.items():
    role = getattr(var, "cf_role", None)
    if role in roles:
        out["roles"][name] = role
    if role != "mesh_topology":
        continue
    for a in ("topology_dimension", "node_coordinates"):
        if a not in var.ncattrs():
            bad(f"{name}: mesh_topology without {a} (UGRID-1.0)")
    dim = int(getattr(var, "topology_dimension", 0))
    if dim not in (1, 2, 3):
        bad(f"{name}: topology_dimension {dim} not 1, 2 or 3")
    coords = str(getattr(var, "node_coordinates", "")).split()
    if len(coords) < 2 or any(c not in v for c in coords):
        bad(f"{name}: node_coordinates {coords} do not name two variables of the file")
        continue
    n_node = v[coords[0]].size
    if any(v[c].dimensions != v[coords[0]].dimensions or v[c].ndim != 1 for c in coords):
        bad(f"{name}: node coordinate variables {coords} do not share one dimension")
    need = {2: ["face_node_connectivity"], 1: ["edge_node_connectivity"], 3: ["volume_node_connectivity"]}.get(dim, [])
    for a in need:
        if a not in var.ncattrs():
            bad(f"{name}: topology_dimension {dim} needs {a}")
    for a in var.ncattrs():
        if not a.endswith("_connectivity"):
            continue
        cname = str(var.getncattr(a))
        if cname not in v:
            bad(f"{name}: {a} names {cname!r}, which is not a variable of the file")
            continue
        c = v[cname]
        if getattr(c, "cf_role", None) != a:
            bad(f"{cname}: cf_role {getattr(c, 'cf_role', None)!r}, expected {a!r}")
        if c.ndim != 2 or c.dtype.kind not in "iu":
            bad(f"{cname}: a connectivity must be a 2-D integer array")
            continue
        start = int(getattr(c, "start_index", 0))
        if start not in (0, 1):
            bad(f"{cname}: start_index {start} is not 0 or 1")
        a_ = np.asarray(c[:])
        fill = getattr(c, "_FillValue", None)
        vals = a_[a_ != fill] if fill is not None else a_.ravel()
        if a.endswith("_node_connectivity") and vals.size and (vals.min() < start or vals.max() >= n_node + start):
            bad(f"{cname}: node indices {vals.min()}..{vals.max()} outside {start}..{n_node + start - 1}")
print(json.dumps(out))
"""


def ugrid_problems(path) -> tuple[dict, list[str]]:
    """The UGRID variables of *path* (name -> cf_role) and the UGRID-1.0 rules they break (checked with
    the checker environment's netCDF4); ``({}, [])`` for a file that does not declare UGRID."""
    import json

    res = subprocess.run([str(BIN / "python"), "-c", UGRID_SCRIPT, str(path), ",".join(UGRID_ROLES)],
                         capture_output=True, text=True)
    if res.returncode:
        return {}, [f"UGRID check failed: {res.stderr.strip().splitlines()[-1] if res.stderr.strip() else res.returncode}"]
    out = json.loads(res.stdout)
    return (out["roles"], out["problems"]) if out["ugrid"] else ({}, [])


def _drop_ugrid_role_errors(text: str, roles: dict) -> tuple[list[str], int]:
    """Message lines of cfchecker's output without its (9.5) cf_role errors for UGRID variables, and how
    many were dropped."""
    var, kept, dropped = None, [], 0
    for ln in text.splitlines():
        m = re.match(r"Checking variable: (\S+)", ln)
        if m:
            var = m.group(1)
        if not ln.startswith(("ERROR:", "WARN:", "WARNING:")) or "Location" in ln:
            continue
        if var in roles and ln.startswith("ERROR:") and "(9.5)" in ln and "cf_role" in ln:
            dropped += 1
            continue
        kept.append(ln)
    return kept, dropped


def cf_check(path, table: Path) -> CfReport:
    """Run cfchecker (CF version from the file's ``Conventions``) on *path*; for a UGRID file, its cf_role
    errors on UGRID variables are replaced by :func:`ugrid_problems`."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "area.xml").write_text(EMPTY.format(tag="area_type_table"))
        (tmp / "region.xml").write_text(EMPTY.format(tag="standardized_region_list"))
        res = subprocess.run([str(BIN / "cfchecks"), "-v", "auto", "-s", str(table), "-a", str(tmp / "area.xml"),
                              "-r", str(tmp / "region.xml"), str(path)], capture_output=True, text=True)
    text = res.stdout + res.stderr
    errors = re.search(r"ERRORS detected: (\d+)", text)
    warns = re.search(r"WARNINGS given: (\d+)", text)
    roles, problems = ugrid_problems(path)
    msgs, dropped = _drop_ugrid_role_errors(text, roles)
    msgs += [f"ERROR: (UGRID-1.0): {p}" for p in problems]
    n_err = int(errors.group(1)) - dropped + len(problems) if errors else -1
    return CfReport(n_err, int(warns.group(1)) if warns else -1, msgs, text)


def gdal_info(path, variable: str = "depth") -> dict | None:
    """``gdalinfo NETCDF:path:variable`` parsed: CRS name, origin and pixel size (None without gdalinfo)."""
    if not shutil.which("gdalinfo"):
        return None
    info = subprocess.run(["gdalinfo", f"NETCDF:{path}:{variable}"], capture_output=True, text=True)
    crs = re.search(r'PROJCRS\["([^"]+)"', info.stdout) or re.search(r'(?:LOCAL_CS|ENGCRS)\["([^"]+)"', info.stdout)
    origin = re.search(r"Origin = \(([^)]+)\)", info.stdout)
    size = re.search(r"Pixel Size = \(([^)]+)\)", info.stdout)
    size_xy = re.search(r"Size is (\d+), (\d+)", info.stdout)
    # a rotated grid (a site whose levee is not along x) is reported as the six geotransform terms instead
    rotated = re.search(r"GeoTransform =\s*\n\s*([^\n]+)\n\s*([^\n]+)", info.stdout)
    num = lambda m: tuple(float(v) for v in m.group(1).split(",")) if m else None
    gt = tuple(float(v) for v in (rotated.group(1) + "," + rotated.group(2)).split(",")) if rotated else None
    return {"returncode": info.returncode, "crs": crs.group(1) if crs else None, "origin": num(origin),
            "pixel_size": num(size), "size": tuple(int(v) for v in size_xy.groups()) if size_xy else None,
            "geotransform": gt, "output": info.stdout + info.stderr}


_CRS_SCRIPT = r"""
import json, sys
import netCDF4
from pyproj import CRS
out = {"problems": [], "grids": []}
with netCDF4.Dataset(sys.argv[1]) as nc:
    mapped = {n: v.getncattr("grid_mapping") for n, v in nc.variables.items() if "grid_mapping" in v.ncattrs()}
    for gm in sorted(set(mapped.values())):
        if gm not in nc.variables:
            out["problems"].append(f"grid_mapping {gm!r} is not a variable")
            continue
        attrs = nc.variables[gm].ncattrs()
        if "crs_wkt" not in attrs:
            continue
        wkt = nc.variables[gm].getncattr("crs_wkt")
        try:
            CRS.from_wkt(wkt)
        except Exception as exc:  # not WKT (e.g. "EPSG:32615" stored as is) or not a CRS
            out["problems"].append(f"{gm}: crs_wkt is not WKT pyproj/GDAL can read ({str(wkt)[:40]!r}: {exc})")
    out["grids"] = [n for n, v in nc.variables.items() if n in mapped and {"x", "y"} <= set(v.dimensions)]
print(json.dumps(out))
"""


def crs_problems(path, variable: str = "depth") -> list[str]:
    """Why GIS would not place *path*'s grid: a ``grid_mapping`` whose ``crs_wkt`` pyproj cannot read, or
    (with gdalinfo) a grid for which GDAL reports no CRS although the file requests one. Empty when the
    CRS is readable or the file requests none. Runs in the checker environment (netCDF4, pyproj)."""
    import json

    python = BIN / "python" if (BIN / "python").exists() else Path(sys.executable)
    res = subprocess.run([str(python), "-c", _CRS_SCRIPT, str(path)], capture_output=True, text=True)
    if res.returncode:
        return [f"cannot inspect the CRS ({res.stderr.strip().splitlines()[-1] if res.stderr.strip() else res.returncode})"]
    out = json.loads(res.stdout)
    problems, grids = out["problems"], out["grids"]
    if problems or not grids or not shutil.which("gdalinfo"):
        return problems
    info = gdal_info(path, variable if variable in grids else grids[0])
    if info["returncode"] != 0 or info["crs"] is None:
        problems.append(f"gdalinfo: no CRS read for {variable if variable in grids else grids[0]} (the file requests one)")
    return problems


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    if argv == ["--setup"]:
        print(f"cfchecker environment: {VENV} (standard-name table {ensure_env()})")
        return 0
    table = ensure_env()
    status = 0
    for f in argv:
        rep = cf_check(f, table)
        print(f"cfchecker {f}: {rep.errors} errors, {rep.warnings} warnings")
        for line in rep.messages:
            print("   ", line)
        if rep.errors != 0 or rep.warnings != 0:
            status = 1
        for problem in crs_problems(f):
            print(f"CRS {f}: {problem}")
            status = 1
        info = gdal_info(f)
        if info is not None and info["returncode"] == 0:
            where = (f"geotransform {info['geotransform']} (rotated)" if info["geotransform"] else
                     f"origin {info['origin'] or '?'}; pixel size {info['pixel_size'] or '?'}")
            print(f"gdalinfo {f}: CRS {info['crs'] or 'none'}; {where}")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
