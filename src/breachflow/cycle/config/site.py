"""The ``[site]`` section of a closure run: a preset scene (``demo_breach``, ``typical_breach``, docs/theory.md, *Breach growth*)
with overrides, or a real site from terrain files (:mod:`breachflow.site.config`), and the site's CRS."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

from ...errors import BreachflowError
from ...scenario.config import register_section
from ...scenario.geometry import BreachGeometry, BreachScene, LeveeGeometry, typical_breach


def demo_breach() -> BreachScene:
    """A small breach for the default run: a 3 m clay levee (crown 3 m, slopes 1V:2H) with water at the
    crest and a 12 m breach to the ground, 30 m of levee each side — the report's typical breach
    (docs/theory.md, *Breach growth*) scaled down so a closure completes in minutes on a laptop."""
    return BreachScene(
        levee=LeveeGeometry(height=3.0, crown_width=3.0, flood_slope=2.0, protected_slope=2.0),
        breach=BreachGeometry(length=12.0, depth=3.0, wall_slope=0.0),
        ground_elevation=0.0, flood_water_elevation=3.0, levee_length_each_side=30.0,
        flood_side_extent=40.0, protected_side_extent=30.0, flood_channel_length=72.0, flood_channel_drop=0.0,
        polder_slope=1.0 / 500.0, manning_n=0.025, name="demo_breach",
        notes={"source": "typical breach of SERRI 70015-001 §2.8 scaled to 3 m"})


SITE_PRESETS = {"typical_breach": typical_breach, "demo_breach": demo_breach}

_SITE_KEYS = {
    "ground_elevation": "length", "flood_water_elevation": "length", "levee_length_each_side": "length",
    "flood_side_extent": "length", "protected_side_extent": "length", "flood_channel_length": "length",
    "flood_channel_drop": "length", "polder_slope": "dimensionless", "manning_n": "manning",
}


@register_section("site")
@dataclass
class SiteSection:
    """``[site]``: ``preset`` (``typical_breach`` | ``demo_breach``), ``crs`` (``EPSG:nnnn``, WKT or PROJ, in
    metres; default the local transverse Mercator :data:`breachflow.field.crs.LOCAL_CRS`) and
    overrides of the scene: ground/flood elevations, extents, channel, ``polder_slope``, ``manning_n``.
    With ``terrain`` the table is a real site instead (:class:`breachflow.site.config.SiteTerrainSection`)."""

    preset: str = "demo_breach"
    crs: str | None = None
    overrides: dict = field(default_factory=dict)

    @classmethod
    def from_table(cls, table, ctx):
        if "terrain" in table:  # a real site: terrain, levee and breach from the user's files
            from ...site.config import SiteTerrainSection

            return SiteTerrainSection.from_table(table, ctx)
        return cls._preset_from_table(table, ctx)

    @classmethod
    def schema_keys(cls) -> dict:
        """The keys of both forms of ``[site]`` (preset scene, terrain site) for the scenario reference."""
        from ...scenario.reference import _Probe
        from ...site.config import SiteTerrainSection

        keys = {}
        for parse in (cls._preset_from_table, SiteTerrainSection.from_table):
            probe = _Probe("site")
            for table in ({}, None):
                if table is None:
                    table = {k: None for k in probe.allowed}
                try:
                    parse(table, probe)
                except Exception:  # the probe's placeholder values: what was asked is recorded
                    pass
            keys.update({k: probe.keys.get(k, {"description": "see the section description"}) for k in probe.allowed})
        return keys

    @classmethod
    def _preset_from_table(cls, table, ctx):
        ctx.check_keys(table, {"preset", "crs", *_SITE_KEYS})
        preset = ctx.raw(table, "preset", default="demo_breach")
        if preset not in SITE_PRESETS:
            raise ctx.error(f"unknown site preset {preset!r}; available: {sorted(SITE_PRESETS)}", "preset")
        over = {}
        for key, kind in _SITE_KEYS.items():
            if key in table:
                over[key] = ctx.quantity(table, key, kind, default_unit="" if kind == "dimensionless" else None,
                                         nonnegative=key not in ("ground_elevation", "flood_water_elevation"))
        crs = ctx.raw(table, "crs")
        if crs:
            try:
                _crs_wkt(crs)
            except BreachflowError as exc:
                raise ctx.error(str(exc).removeprefix("[site] crs: "), "crs") from None
        return cls(preset, crs, over)

    def scene(self, levee=None, breach=None) -> BreachScene:
        sc = SITE_PRESETS[self.preset]()
        sc = replace(sc, **self.overrides)
        if levee is not None:
            sc = replace(sc, levee=levee)
        if breach is not None:
            sc = replace(sc, breach=breach)
        return sc


def _crs_wkt(crs: str | None) -> str:
    """WKT of the site's CRS (``EPSG:nnnn``, WKT, PROJ; in metres: site coordinates are metres); the
    default is the documented local projected CRS :data:`~breachflow.field.crs.LOCAL_CRS`."""
    from ...field.crs import local_crs_wkt, resolve_crs

    if not crs:
        return local_crs_wkt()
    return resolve_crs(crs, where="[site] crs", data_unit="m")
