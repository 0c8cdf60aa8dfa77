"""Write the example site: a synthetic lidar-like DEM of a river levee and its centreline (issue 13).

    python examples/site/make_site.py [OUT_DIR]        # default: this directory
    python examples/site/make_site.py OUT_DIR --angle 137   # the same site turned 137° counter-clockwise

Writes ``terrain.tif`` (GeoTIFF, float32, 1 m pixels, NAD83 / UTM zone 15N, EPSG:26915, elevations in m
rounded to 1 cm like a lidar product) and ``levee.geojson`` (the levee centreline, same CRS). The scene,
deterministic (fixed seed), from south to north: a river channel (bed −4 m) flowing east, its bank up to
a batture at +2 m, a clay levee (crest +5 m, crown 3 m, slopes 1V:3H) whose centreline runs east at
northing 3 372 100 m and bends 8° north 70 m east of the breach site, and a polder whose ground falls
away from the landside toe (+1.8 m) at 1:500 with a drainage ditch; a gentle undulation (±10 cm over
tens of metres) and lidar noise (σ 3 cm) everywhere.

``angle`` (degrees, counter-clockwise) turns the whole scene about the example breach centre
:data:`PIVOT`: the levee then runs at that angle there and the DEM (still north-up, 1 m pixels) is the
bounding box of the turned 240 m x 200 m scene; 0 writes exactly the committed files.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

EPSG = 26915
WEST, SOUTH = 676000.0, 3371980.0   # south-west corner of the DEM (m)
NX, NY, PIXEL = 240, 200, 1.0       # 240 m x 200 m at 1 m
LEVEE_Y = 3372100.0                 # northing of the levee centreline
LEVEE = [(WEST - 5.0, LEVEE_Y), (WEST + 190.0, LEVEE_Y), (WEST + 250.0, LEVEE_Y + 60.0 * np.tan(np.radians(8.0)))]
CREST, BATTURE, TOE_POLDER = 5.0, 2.0, 1.8
CROWN, SLOPE = 3.0, 3.0             # crown width (m), side slopes 1V:3H
PIVOT = (WEST + 120.0, LEVEE_Y)     # the breach centre of site.toml (chainage 125 m): the scene turns about it


def turn(X, Y, angle):
    """Points (X, Y) turned *angle* degrees counter-clockwise about :data:`PIVOT`."""
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    dx, dy = np.asarray(X, float) - PIVOT[0], np.asarray(Y, float) - PIVOT[1]
    return PIVOT[0] + c * dx - s * dy, PIVOT[1] + s * dx + c * dy


def raster_grid(angle=0.0):
    """(west, north, nx, ny) of the DEM of the scene turned by *angle*: whole pixels around it."""
    if angle == 0:
        return WEST, SOUTH + NY * PIXEL, NX, NY
    cx, cy = turn(np.array([WEST, WEST + NX * PIXEL] * 2), np.array([SOUTH] * 2 + [SOUTH + NY * PIXEL] * 2), angle)
    west, south = np.floor(cx.min() / PIXEL) * PIXEL, np.floor(cy.min() / PIXEL) * PIXEL
    east, north = np.ceil(cx.max() / PIXEL) * PIXEL, np.ceil(cy.max() / PIXEL) * PIXEL
    return west, north, int(round((east - west) / PIXEL)), int(round((north - south) / PIXEL))


def levee_line(angle=0.0):
    """The levee centreline vertices of the scene turned by *angle*."""
    x, y = turn(*np.array(LEVEE).T, angle)
    return list(zip(x.tolist(), y.tolist())) if angle else [tuple(map(float, p)) for p in LEVEE]


def levee_frame(X, Y):
    """Chainage-free signed offset from the centreline (positive north, i.e. left of the eastward line)."""
    import shapely

    line = shapely.LineString(LEVEE)
    pts = shapely.points(X.ravel(), Y.ravel())
    dist = shapely.distance(pts, line).reshape(X.shape)
    s = shapely.line_locate_point(line, pts)
    near = shapely.line_interpolate_point(line, s)
    side = np.sign(Y.ravel() - shapely.get_y(near)).reshape(X.shape)
    return dist * np.where(side == 0, 1.0, side)


def dem(angle: float = 0.0) -> np.ndarray:
    """Elevation (m) at the pixel centres, rows from north to south (GeoTIFF order), of the scene turned
    by *angle* (the scene's formulas evaluated at the pixel centres turned back)."""
    rng = np.random.default_rng(20261123)
    west, north, nx, ny = raster_grid(angle)
    x = west + (np.arange(nx) + 0.5) * PIXEL
    y = north - (np.arange(ny) + 0.5) * PIXEL
    X, Y = np.meshgrid(x, y)
    if angle:
        X, Y = turn(X, Y, -angle)
    d = levee_frame(X, Y)
    half = 0.5 * CROWN
    toe = half + (CREST - BATTURE) * SLOPE
    # flood side: batture, bank 1V:4H down to the channel bed at -4 m, 35 m beyond the levee toe
    bank = toe + 25.0
    z = np.where(d < 0, np.maximum(BATTURE - np.clip(-d - bank, 0, None) / 4.0, -4.0), 0.0)
    # protected side: the polder falls away from the toe at 1:500, a 1 m deep drainage ditch 60 m out
    zp = TOE_POLDER - np.clip(d - toe, 0, None) / 500.0
    zp -= 1.0 * np.exp(-((d - 60.0) / 2.0) ** 2)
    z = np.where(d >= 0, zp, z)
    # the levee body: crest, crown, slopes (only above the ground it stands on)
    body = CREST - np.clip(np.abs(d) - half, 0, None) / SLOPE
    z = np.maximum(z, np.where(np.abs(d) <= toe, body, -np.inf))
    # natural relief and lidar noise
    z += 0.1 * np.sin((X - WEST) / 37.0) * np.cos((Y - SOUTH) / 23.0)
    z += rng.normal(0.0, 0.03, z.shape)
    return np.round(z, 2).astype("float32")


def write(out: Path, angle: float = 0.0) -> tuple[Path, Path]:
    import rasterio
    from rasterio.transform import from_origin

    out.mkdir(parents=True, exist_ok=True)
    tif = out / "terrain.tif"
    west, north, nx, ny = raster_grid(angle)
    profile = dict(driver="GTiff", width=nx, height=ny, count=1, dtype="float32", crs=f"EPSG:{EPSG}",
                   transform=from_origin(west, north, PIXEL, PIXEL), nodata=-9999.0,
                   compress="deflate", predictor=3, tiled=False)
    with rasterio.open(tif, "w", **profile) as dst:
        dst.write(dem(angle), 1)
        dst.set_band_unit(1, "m")
        dst.update_tags(TIFFTAG_DATETIME="2026:11:23 00:00:00", source="breachflow examples/site/make_site.py (synthetic)")
    geo = out / "levee.geojson"
    doc = {"type": "FeatureCollection", "name": "levee",
           "crs": {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{EPSG}"}},
           "features": [{"type": "Feature", "properties": {"name": "example levee centreline"},
                         "geometry": {"type": "LineString", "coordinates": [list(map(float, p)) for p in levee_line(angle)]}}]}
    geo.write_text(json.dumps(doc, indent=1) + "\n")
    return tif, geo


if __name__ == "__main__":
    args = sys.argv[1:]
    turn_by = 0.0
    if "--angle" in args:
        i = args.index("--angle")
        turn_by = float(args[i + 1])
        del args[i:i + 2]
    target = Path(args[0]) if args else Path(__file__).resolve().parent
    for p in write(target, turn_by):
        print(p, p.stat().st_size, "bytes")
