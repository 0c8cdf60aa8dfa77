#!/usr/bin/env python3
"""Check breachflow NetCDF files with the CF checker (cfchecker) and GDAL, offline.

    python3 tools/cf_check.py FILE.nc [FILE.nc ...]
    python3 tools/cf_check.py --setup        # only create the checker environment (``tasks.py test`` does)

Sets up ``.venv-cfcheck`` once (cfchecker, and compliance-checker only for the CF standard-name table it
ships, so nothing is fetched from the web). cfchecker also wants the CF area-type and region-name tables;
breachflow files use neither (no ``where`` cell methods, no region variables), so empty tables are passed.
cfchecker needs the UDUNITS-2 library (Debian: ``apt-get install libudunits2-0``); the GDAL check runs
when ``gdalinfo`` is on PATH (Debian: ``gdal-bin``) and prints each grid's CRS and geotransform.
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


def cf_check(path, table: Path) -> CfReport:
    """Run cfchecker (CF version from the file's ``Conventions``) on *path*."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "area.xml").write_text(EMPTY.format(tag="area_type_table"))
        (tmp / "region.xml").write_text(EMPTY.format(tag="standardized_region_list"))
        res = subprocess.run([str(BIN / "cfchecks"), "-v", "auto", "-s", str(table), "-a", str(tmp / "area.xml"),
                              "-r", str(tmp / "region.xml"), str(path)], capture_output=True, text=True)
    text = res.stdout + res.stderr
    errors = re.search(r"ERRORS detected: (\d+)", text)
    warns = re.search(r"WARNINGS given: (\d+)", text)
    msgs = [ln for ln in text.splitlines() if ln.startswith(("ERROR:", "WARN:", "WARNING:")) and "Location" not in ln]
    return CfReport(int(errors.group(1)) if errors else -1, int(warns.group(1)) if warns else -1, msgs, text)


def gdal_info(path, variable: str = "depth") -> dict | None:
    """``gdalinfo NETCDF:path:variable`` parsed: CRS name, origin and pixel size (None without gdalinfo)."""
    if not shutil.which("gdalinfo"):
        return None
    info = subprocess.run(["gdalinfo", f"NETCDF:{path}:{variable}"], capture_output=True, text=True)
    crs = re.search(r'PROJCRS\["([^"]+)"', info.stdout) or re.search(r'(?:LOCAL_CS|ENGCRS)\["([^"]+)"', info.stdout)
    origin = re.search(r"Origin = \(([^)]+)\)", info.stdout)
    size = re.search(r"Pixel Size = \(([^)]+)\)", info.stdout)
    size_xy = re.search(r"Size is (\d+), (\d+)", info.stdout)
    num = lambda m: tuple(float(v) for v in m.group(1).split(",")) if m else None
    return {"returncode": info.returncode, "crs": crs.group(1) if crs else None, "origin": num(origin),
            "pixel_size": num(size), "size": tuple(int(v) for v in size_xy.groups()) if size_xy else None,
            "output": info.stdout + info.stderr}


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
            print(f"gdalinfo {f}: CRS {info['crs'] or 'none'}; origin {info['origin'] or '?'}; "
                  f"pixel size {info['pixel_size'] or '?'}")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
