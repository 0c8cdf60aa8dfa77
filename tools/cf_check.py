#!/usr/bin/env python3
"""Check breachflow NetCDF files with the CF checker (cfchecker) and GDAL, offline.

    python3 tools/cf_check.py FILE.nc [FILE.nc ...]

Sets up ``.venv-cfcheck`` once (cfchecker, and compliance-checker only for the CF standard-name table it
ships, so nothing is fetched from the web). cfchecker also wants the CF area-type and region-name tables;
breachflow files use neither (no ``where`` cell methods, no region variables), so empty tables are passed.
cfchecker needs the UDUNITS-2 library (Debian: ``apt-get install libudunits2-0``); the GDAL check runs
when ``gdalinfo`` is on PATH (Debian: ``gdal-bin``) and prints each grid's CRS and geotransform.
Exits non-zero when cfchecker reports an error or a warning.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VENV = ROOT / ".venv-cfcheck"
BIN = VENV / "bin"
EMPTY = """<?xml version="1.0"?>
<{tag}>
  <version_number>0</version_number>
  <date>2026-01-01</date>
  <last_modified>2026-01-01T00:00:00Z</last_modified>
</{tag}>
"""


def ensure_env() -> Path:
    if not (BIN / "cfchecks").exists():
        venv.EnvBuilder(with_pip=True).create(VENV)
        subprocess.run([str(BIN / "pip"), "install", "-q", "--disable-pip-version-check", "cfchecker", "compliance-checker"], check=True)
    out = subprocess.run([str(BIN / "python"), "-c",
                          "import compliance_checker, os; print(os.path.dirname(compliance_checker.__file__))"],
                         check=True, capture_output=True, text=True).stdout.strip()
    return Path(out) / "data" / "cf-standard-name-table.xml"


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    table = ensure_env()
    tmp = Path(tempfile.mkdtemp())
    (tmp / "area.xml").write_text(EMPTY.format(tag="area_type_table"))
    (tmp / "region.xml").write_text(EMPTY.format(tag="standardized_region_list"))
    status = 0
    for f in argv:
        res = subprocess.run([str(BIN / "cfchecks"), "-v", "auto", "-s", str(table), "-a", str(tmp / "area.xml"),
                              "-r", str(tmp / "region.xml"), f], capture_output=True, text=True)
        text = res.stdout + res.stderr
        errors = re.search(r"ERRORS detected: (\d+)", text)
        warns = re.search(r"WARNINGS given: (\d+)", text)
        ne = int(errors.group(1)) if errors else -1
        nw = int(warns.group(1)) if warns else -1
        print(f"cfchecker {f}: {ne} errors, {nw} warnings")
        for line in text.splitlines():
            if line.startswith(("ERROR:", "WARN:", "WARNING:")) and "Location" not in line:
                print("   ", line)
        if ne != 0 or nw != 0:
            status = 1
        if shutil.which("gdalinfo"):
            info = subprocess.run(["gdalinfo", f"NETCDF:{f}:depth"], capture_output=True, text=True)
            if info.returncode == 0:
                crs = re.search(r'PROJCRS\["([^"]+)"', info.stdout) or re.search(r'(LOCAL_CS|ENGCRS)\["([^"]+)"', info.stdout)
                origin = re.search(r"Origin = \(([^)]+)\)", info.stdout)
                size = re.search(r"Pixel Size = \(([^)]+)\)", info.stdout)
                print(f"gdalinfo {f}: CRS {crs.group(1) if crs else 'none'}; origin ({origin.group(1) if origin else '?'}); "
                      f"pixel size ({size.group(1) if size else '?'})")
    shutil.rmtree(tmp)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
