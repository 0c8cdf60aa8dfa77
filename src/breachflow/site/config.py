"""``[site]`` of a real site: the scenario keys of a terrain site (issue 13).

The ``[site]`` section (registered in :mod:`breachflow.cycle.config`) hands a table with ``terrain`` to
:meth:`SiteTerrainSection.from_table`. Keys (paths relative to the scenario file, quantities with units)::

    [site]
    terrain = "terrain.tif"          # GeoTIFF / ESRI ASCII (.asc + .prj) / NetCDF terrain elevations
    terrain_units = "ft"             # vertical unit when the file does not declare it (default m)
    terrain_variable = "elevation"   # NetCDF only
    crs = "EPSG:26915"               # when the terrain has none (must agree when it has one)
    levee = "levee.geojson"          # centreline: GeoJSON / shapefile / GeoPackage; or levee_coords = [[x, y], ...]
    breach_at = "120 m"              # chainage of the breach centre from the line's first vertex
    breach_length = "12 m"           # at the crest
    breach_polygon = "breach.geojson"   # instead of breach_at + breach_length
    breach_bottom = "2.0 m"          # elevation
    breach_wall_slope = 0.5          # 1V:mH (default 0.5: 2V:1H), 0 vertical
    flood_level = "4.7 m"            # or flood_stage = "stage.csv" (time [h], stage [ft])
    flood_side = "right"             # of the levee line's direction; default from the terrain
    manning_n = 0.03
    extent_along = "36 m"            # beyond each breach end; extent_flood / extent_protected from the centreline
    boundaries = { west = "outflow" }   # per side: level | outflow | wall
    absorbing = true                 # absorbing flood-level boundary
"""
from __future__ import annotations

from dataclasses import dataclass

from .domain import SiteSpec

KEYS = {"terrain", "terrain_units", "terrain_variable", "crs", "levee", "levee_coords", "breach_at", "breach_length",
        "breach_polygon", "breach_bottom", "breach_wall_slope", "flood_level", "flood_stage", "flood_side", "manning_n",
        "extent_along", "extent_flood", "extent_protected", "boundaries", "absorbing"}


@dataclass
class SiteTerrainSection:
    """Parsed ``[site]`` of a terrain site; :meth:`build` makes the :class:`~.domain.Site`."""

    spec: SiteSpec

    @property
    def crs(self):
        return self.spec.crs

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, KEYS, subtables=("boundaries",))
        if "levee" not in table and "levee_coords" not in table:
            raise ctx.error("a terrain site needs levee = FILE or levee_coords = [[x, y], ...]", "terrain")
        coords = ctx.raw(table, "levee_coords", types=(list,))
        if coords is not None:
            try:
                coords = [[float(a), float(b)] for a, b in coords]
            except (TypeError, ValueError):
                raise ctx.error("expected a list of [x, y] pairs", "levee_coords") from None
        q = lambda k, kind, **kw: ctx.quantity(table, k, kind, **kw)
        spec = SiteSpec(
            terrain=ctx.file(table, "terrain"), levee=ctx.file(table, "levee"), levee_coords=coords,
            crs=ctx.raw(table, "crs"), terrain_units=ctx.raw(table, "terrain_units"),
            terrain_variable=ctx.raw(table, "terrain_variable"),
            breach_at=q("breach_at", "length", nonnegative=True), breach_length=q("breach_length", "length", positive=True),
            breach_polygon=ctx.file(table, "breach_polygon"), breach_bottom=q("breach_bottom", "length"),
            breach_wall_slope=q("breach_wall_slope", "dimensionless", default=SiteSpec.breach_wall_slope,
                                default_unit="", nonnegative=True),
            flood_level=q("flood_level", "length"), flood_stage=ctx.file(table, "flood_stage"),
            flood_side=ctx.raw(table, "flood_side"),
            manning_n=q("manning_n", "manning", default=SiteSpec.manning_n, default_unit="s/m**(1/3)", nonnegative=True),
            extent_along=q("extent_along", "length", positive=True), extent_flood=q("extent_flood", "length", positive=True),
            extent_protected=q("extent_protected", "length", positive=True),
            boundaries=ctx.raw(table, "boundaries", types=(dict,), default={}),
            absorbing=ctx.raw(table, "absorbing", types=(bool,), default=SiteSpec.absorbing), scenario=ctx.path,
        )
        if spec.flood_level is None and spec.flood_stage is None:
            raise ctx.error("give flood_level or flood_stage", "terrain")
        if spec.flood_level is not None and spec.flood_stage is not None:
            raise ctx.error("give flood_level or flood_stage, not both", "flood_stage")
        if spec.breach_polygon is None and (spec.breach_at is None or spec.breach_length is None):
            raise ctx.error("give breach_at and breach_length, or breach_polygon", "terrain")
        if spec.breach_bottom is None:
            raise ctx.error("required key 'breach_bottom' is missing", None)
        return cls(spec)

    def build(self, resolution: float, *, align: bool = True):
        from .domain import build_site

        return build_site(self.spec, resolution, align=align)
