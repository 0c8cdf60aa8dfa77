"""Write the example levee district: a synthetic lidar-like terrain of a river levee several kilometres long
with bends, and its centreline.

    python examples/district/make_district.py [OUT_DIR]                    # default: this directory
    python examples/district/make_district.py OUT_DIR --length 20000       # a 20 km levee (benchmarks)

Writes ``terrain.tif`` (GeoTIFF, float32 rounded to 1 cm, NAD83 / UTM zone 15N, EPSG:26915, DEFLATE) and
``levee.geojson`` (the centreline, same CRS, digitised downstream). Deterministic (fixed seed).

The scene across the levee, from the river (left of the line's direction) to the polder (right):
a river bed at -3 m, a bank rising to a batture at +1.0 m 60-120 m from the centreline, a clay levee
(crown 4 m, slopes 1V:3H) whose crest varies along the line between about +5.2 and +6.8 m, and a polder
whose ground at the landside toe varies between about -0.6 and +1.4 m and falls away 1:1000. The
centreline bends every 1.2-2 km by 10-35 degrees. Flood level of ``district.toml``: +5.0 m.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

EPSG = 26915
ORIGIN = (640000.0, 3340000.0)      # first vertex of the centreline (m)
PIXEL = 4.0                          # terrain pixel (m)
CROWN, SLOPE = 4.0, 3.0              # crown width (m), side slopes 1V:3H
RIVER_BED, BATTURE = -3.0, 1.0
FLOOD_REACH, PROTECTED_REACH = 260.0, 420.0   # least terrain extent each side of the centreline (m)


def crest(s):
    """Levee crest elevation (m) at chainage *s* (m)."""
    return 6.0 + 0.5 * np.sin(2 * np.pi * s / 3100.0) + 0.3 * np.sin(2 * np.pi * s / 870.0 + 0.7)


def polder_toe(s):
    """Polder ground at the landside toe (m) at chainage *s* (m)."""
    return 0.4 + 0.7 * np.sin(2 * np.pi * s / 2300.0 + 1.0) + 0.3 * np.sin(2 * np.pi * s / 650.0)


def centreline(length: float, seed: int = 7) -> np.ndarray:
    """Vertices of a centreline of *length* metres heading roughly east, with bends every 1.2-2 km."""
    rng = np.random.default_rng(seed)
    pts, heading, s = [np.array(ORIGIN)], 0.0, 0.0
    while s < length:
        step = min(rng.uniform(1200.0, 2000.0), length - s)
        turn = np.radians(rng.uniform(10.0, 35.0)) * (1 if rng.random() < 0.5 else -1)
        heading = float(np.clip(heading + turn, -np.radians(40.0), np.radians(40.0)))
        pts.append(pts[-1] + step * np.array([np.cos(heading), np.sin(heading)]))
        s += step
    return np.array(pts)


def frame(line: np.ndarray, X: np.ndarray, Y: np.ndarray):
    """Chainage and signed distance (positive left of the line's direction) of points to the polyline."""
    best = np.full(X.shape, np.inf)
    chain = np.zeros(X.shape)
    sign = np.ones(X.shape)
    s0 = 0.0
    for a, b in zip(line[:-1], line[1:]):
        t = b - a
        L = float(np.hypot(*t))
        t = t / L
        px, py = X - a[0], Y - a[1]
        along = np.clip(px * t[0] + py * t[1], 0.0, L)
        dx, dy = px - along * t[0], py - along * t[1]
        dist = np.hypot(dx, dy)
        closer = dist < best
        best = np.where(closer, dist, best)
        chain = np.where(closer, s0 + along, chain)
        sign = np.where(closer, np.where(t[0] * py - t[1] * px >= 0, 1.0, -1.0), sign)
        s0 += L
    return chain, sign * best


def terrain(line: np.ndarray, seed: int = 11):
    """(x, y, z) of the north-up terrain around *line*: cell-centre axes and elevations (m)."""
    pad = max(FLOOD_REACH, PROTECTED_REACH)
    west, east = np.floor((line[:, 0].min() - pad) / PIXEL) * PIXEL, np.ceil((line[:, 0].max() + pad) / PIXEL) * PIXEL
    south, north = np.floor((line[:, 1].min() - pad) / PIXEL) * PIXEL, np.ceil((line[:, 1].max() + pad) / PIXEL) * PIXEL
    x = np.arange(west + PIXEL / 2, east, PIXEL)
    y = np.arange(south + PIXEL / 2, north, PIXEL)
    X, Y = np.meshgrid(x, y)
    s, d = frame(line, X, Y)
    zc, zp = crest(s), polder_toe(s)
    half = CROWN / 2
    levee_flood = zc - np.maximum(d - half, 0.0) / SLOPE          # d > 0: river side
    levee_land = zc - np.maximum(-d - half, 0.0) / SLOPE          # d < 0: polder side
    toe_land = half + (zc - zp) * SLOPE
    polder = zp - np.maximum(-d - toe_land, 0.0) / 1000.0
    bank = np.interp(d, [0.0, 60.0, 120.0, 160.0, 1e6], [BATTURE, BATTURE, BATTURE, RIVER_BED, RIVER_BED])
    z = np.where(d >= 0, np.maximum(levee_flood, bank), np.maximum(levee_land, polder))
    rng = np.random.default_rng(seed)
    z = z + 0.03 * rng.standard_normal(z.shape)
    return x, y, np.round(z, 2).astype("float32")


def write(out: Path, length: float = 6000.0) -> tuple[Path, Path]:
    import rasterio
    from rasterio.transform import from_origin

    out.mkdir(parents=True, exist_ok=True)
    line = centreline(length)
    x, y, z = terrain(line)
    transform = from_origin(x[0] - PIXEL / 2, y[-1] + PIXEL / 2, PIXEL, PIXEL)
    tif = out / "terrain.tif"
    with rasterio.open(tif, "w", driver="GTiff", width=x.size, height=y.size, count=1, dtype="float32",
                       crs=f"EPSG:{EPSG}", transform=transform, nodata=-9999.0, compress="deflate",
                       predictor=3, tiled=True) as dst:
        dst.write(z[::-1][None])
        dst.set_band_unit(1, "m")
    gj = out / "levee.geojson"
    gj.write_text(json.dumps({
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{EPSG}"}},
        "features": [{"type": "Feature", "properties": {"name": "example district levee"},
                      "geometry": {"type": "LineString", "coordinates": [[round(float(a), 2), round(float(b), 2)]
                                                                         for a, b in line]}}]}, indent=1) + "\n")
    return tif, gj



def district_toml(terrain, levee, *, spacing: str = "400 m", flow: str = "weir", resolution: str = "16 m",
                  name: str | None = None) -> str:
    """The atlas scenario of a district on the *terrain* and *levee* files :func:`write` makes: the flood,
    polder and breach growth of ``district.toml`` with candidate breaches every *spacing*, the breach's
    open flow by *flow* (``weir`` or ``swe`` at *resolution*) and two delivery methods (split barges, end
    dumping). A quick district for tests and the atlas benchmark."""
    title = f'name = "{name}"\n' if name else ""
    return f"""
[district]
{title}terrain = "{terrain}"
levee = "{levee}"
flood_side = "left"
spacing = "{spacing}"
margin = "100 m"

[flood]
level = "5.0 m"
fall_rate = "1 cm/h"

[polder]
area = "12000 ha"
inundation_depth = "1 m"
pump_capacity = "5 m^3/s"

[breach]
growth = "verheij_clay"
max_length = "von_thun_gillette"
development_time = "12 h"
flow = "{flow}"
resolution = "{resolution}"

[methods.split_barge]
capacity = "1000 t/h"
mobilisation = "24 h"

[methods.end_dumping]
capacity = "350 t/h"
working_hours = "16 h"
mobilisation = "12 h"
"""

if __name__ == "__main__":
    args = sys.argv[1:]
    length = 6000.0
    if "--length" in args:
        i = args.index("--length")
        length = float(args[i + 1])
        del args[i:i + 2]
    target = Path(args[0]) if args else Path(__file__).resolve().parent
    for p in write(target, length):
        print(f"wrote {p}")
