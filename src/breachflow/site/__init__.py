"""A real site: terrain, levee and breach from the user's files, and the domain around the breach (issue 13).

>>> from breachflow.site import build_site, SiteSpec   # doctest: +SKIP
>>> site = build_site(SiteSpec(terrain="terrain.tif", levee="levee.geojson", breach_at=120, breach_length=12,
...                            breach_bottom=2.0, flood_level=4.7), resolution=1.0)   # doctest: +SKIP
"""
from .domain import Site, SiteSpec, build_site
from .frame import GridFrame
from .geometry import Breach, LeveeLine, load_levee
from .terrain import Terrain, load_terrain

__all__ = ["Site", "SiteSpec", "build_site", "GridFrame", "Breach", "LeveeLine", "load_levee", "Terrain", "load_terrain"]
