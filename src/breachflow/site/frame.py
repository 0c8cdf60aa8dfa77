"""The breach-aligned grid of a site and how its outputs land on the map (issue 13).

A levee can run in any direction. The hydrodynamic grid of a site is built in *grid coordinates*: the
site CRS rotated by the levee's direction at the breach ``θ`` about the breach centre ``c``, so that the
levee at the breach runs along the grid's x axis (the closure cycle, its breach section and criteria are
unchanged). A point's map (CRS) coordinates are::

    (X, Y) = c + R(θ) · ((x, y) − c),     R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]

with ``θ`` counter-clockwise from the CRS x axis, in (−90°, 90°]; ``θ = 0`` (a levee running along x)
makes grid and map coordinates the same, and the outputs are exactly those of an axis-aligned grid.

Cycle files of a rotated grid (:meth:`GridFrame.georeference`):

* ``x``, ``y``: 1-D grid coordinates (no ``standard_name``/``axis``, so that GDAL does not take them
  for map coordinates); ``map_x``, ``map_y``: 2-D projection coordinates of the cell centres in the
  site CRS (CF auxiliary coordinates, named in every field's ``coordinates``);
* ``crs``: the CRS as before plus GDAL's ``GeoTransform`` (with rotation terms; row 0 = first stored
  row): ``gdalinfo`` and rasterio (GDAL) place the grid on the map;
* ``u``, ``v``: grid-relative components (CF ``barotropic_sea_water_x/y_velocity`` are along the grid
  axes); ``u_east``, ``v_north``: the same velocity in east/north (CRS axis) components;
* particles: ``particle_x``/``particle_y`` (and velocities) in grid coordinates as the DEM uses them;
  ``particle_map_x``, ``particle_map_y`` in the site CRS;
* global ``grid_rotation_deg`` (θ) and ``grid_rotation_centre`` (c, "X Y").
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: attributes of the grid coordinates of a rotated grid
GRID_COORD_ATTRS = {
    "x": {"long_name": "x of cell centre in the breach-aligned grid (along the levee at the breach)", "units": "m"},
    "y": {"long_name": "y of cell centre in the breach-aligned grid (across the levee at the breach)", "units": "m"},
}
FRAME_NOTE = ("breach-aligned grid rotated by grid_rotation_deg (counter-clockwise from the CRS x axis) about "
              "grid_rotation_centre: map = centre + R(angle) (grid - centre). x, y, u, v, particle_x, particle_y and "
              "the particle velocities are grid components; map_x, map_y, u_east, v_north, particle_map_x and "
              "particle_map_y are in the CRS of the crs variable, whose GeoTransform places the grid for GDAL")


def levee_angle(tangent) -> float:
    """θ (degrees, in (−90, 90]) of the line direction *tangent* from the CRS x axis (the line's sense ignored)."""
    a = math.degrees(math.atan2(float(tangent[1]), float(tangent[0])))
    if a > 90.0:
        a -= 180.0
    elif a <= -90.0:
        a += 180.0
    return a


@dataclass(frozen=True)
class GridFrame:
    """Grid ↔ map coordinates: rotation ``angle_deg`` (θ) about ``centre`` (c); see the module docstring."""

    angle_deg: float = 0.0
    centre: tuple = (0.0, 0.0)

    @property
    def rotated(self) -> bool:
        return self.angle_deg != 0.0

    @property
    def _cs(self):
        a = math.radians(self.angle_deg)
        return math.cos(a), math.sin(a)

    def to_map(self, x, y):
        """Map (CRS) coordinates of grid points (x, y)."""
        c, s = self._cs
        dx, dy = np.asarray(x, float) - self.centre[0], np.asarray(y, float) - self.centre[1]
        return self.centre[0] + c * dx - s * dy, self.centre[1] + s * dx + c * dy

    def to_grid(self, X, Y):
        """Grid coordinates of map points (X, Y)."""
        c, s = self._cs
        dx, dy = np.asarray(X, float) - self.centre[0], np.asarray(Y, float) - self.centre[1]
        return self.centre[0] + c * dx + s * dy, self.centre[1] - s * dx + c * dy

    def vector_to_map(self, u, v):
        """East/north (CRS-axis) components of a vector with grid components (u, v)."""
        c, s = self._cs
        u, v = np.asarray(u, float), np.asarray(v, float)
        return c * u - s * v, s * u + c * v

    def vector_to_grid(self, ue, vn):
        c, s = self._cs
        ue, vn = np.asarray(ue, float), np.asarray(vn, float)
        return c * ue + s * vn, -s * ue + c * vn

    def bearing(self, grid_direction) -> float:
        """Compass bearing (degrees clockwise from the CRS +y axis, "north") of a grid direction."""
        e, n = self.vector_to_map(*grid_direction)
        return math.degrees(math.atan2(float(e), float(n))) % 360.0

    def geotransform(self, x, y) -> list[float]:
        """GDAL's geotransform of a grid with cell centres *x*, *y* (increasing; pixel (col, row) =
        (i, j) is cell ``[j, i]``): ``X = GT0 + col GT1 + row GT2``, ``Y = GT3 + col GT4 + row GT5``."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        dx = float(x[1] - x[0]) if x.size > 1 else 1.0
        dy = float(y[1] - y[0]) if y.size > 1 else 1.0
        X0, Y0 = self.to_map(x[0] - 0.5 * dx, y[0] - 0.5 * dy)
        c, s = self._cs
        return [float(X0), c * dx, -s * dy, float(Y0), s * dx, c * dy]

    def attrs(self) -> dict:
        """Global attributes naming the frame (added to every output of a rotated grid)."""
        return {"grid_rotation_deg": float(self.angle_deg),
                "grid_rotation_centre": f"{self.centre[0]:.3f} {self.centre[1]:.3f}", "grid_frame_note": FRAME_NOTE}

    def georeference(self, ds):
        """*ds* (a cycle's grid + particles, grid coordinates) with its map coordinates; unchanged when
        the grid is not rotated. Idempotent."""
        if not self.rotated:
            return ds
        ds = ds.drop_vars([v for v in ("map_x", "map_y", "u_east", "v_north", "particle_map_x", "particle_map_y")
                           if v in ds.variables])
        for k in ("x", "y"):
            ds[k].attrs = dict(GRID_COORD_ATTRS[k])
        X, Y = self.to_map(*np.meshgrid(ds["x"].values, ds["y"].values))
        gm = {"grid_mapping": "crs"} if "crs" in ds.variables else {}
        ds = ds.assign_coords(
            map_x=(("y", "x"), X, {"standard_name": "projection_x_coordinate", "long_name": "x of cell centre in the site CRS",
                                   "units": "m", **gm}),
            map_y=(("y", "x"), Y, {"standard_name": "projection_y_coordinate", "long_name": "y of cell centre in the site CRS",
                                   "units": "m", **gm}))
        if "crs" in ds.variables:
            ds["crs"].attrs["GeoTransform"] = " ".join(repr(v) for v in self.geotransform(ds["x"].values, ds["y"].values))
        if "u" in ds and "v" in ds:
            ue, vn = self.vector_to_map(ds["u"].values, ds["v"].values)
            # GIS tools pair two grids into one vector by their long names ("x component of NAME" and "y component
            # of NAME": QGIS's mesh layers draw them as arrows), so only the map components are named so here
            for name, val, std, comp in (("u_east", ue, "barotropic_eastward_sea_water_velocity", "x"),
                                         ("v_north", vn, "barotropic_northward_sea_water_velocity", "y")):
                ds[name] = (ds["u"].dims, val, {"standard_name": std, "units": "m s-1", **gm,
                                                 "long_name": f"{comp} component of depth-averaged velocity in the site CRS"})
            for k, axis in (("u", "x"), ("v", "y")):
                ds[k].attrs["long_name"] = f"depth-averaged velocity along the breach-aligned grid's {axis} axis"
                ds[k].attrs["comment"] = "component along the grid axis (breach-aligned grid), not east/north"
        if "particle_x" in ds and "particle_y" in ds:
            PX, PY = self.to_map(ds["particle_x"].values, ds["particle_y"].values)
            for k in ("particle_x", "particle_y"):
                ds[k].attrs.pop("grid_mapping", None)
                ds[k].attrs.pop("standard_name", None)
                ds[k].attrs["long_name"] = f"particle centre, {k[-1]} in the breach-aligned grid"
            for name, val, std in (("particle_map_x", PX, "projection_x_coordinate"),
                                   ("particle_map_y", PY, "projection_y_coordinate")):
                ds[name] = (ds["particle_x"].dims, val, {"standard_name": std, "units": "m", **gm,
                                                          "long_name": f"particle centre, {name[-1]} in the site CRS"})
        ds.attrs.update(self.attrs())
        return ds
