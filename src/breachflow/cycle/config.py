"""Scenario-file sections of a closure run: ``[site]``, ``[hydro]``, ``[dem]``, ``[fluid]``,
``[placement]``, ``[criteria]``, ``[closure]`` (SPEC §3, §4, §5, §6, §7).

``[levee]`` and ``[breach]`` (length, depth, wall_slope, scour_depth) of the scenario override the site
preset's geometry; ``[flood]`` and ``[polder]``, when present, give the closure window the run is
judged against. :func:`closure_setup` turns a parsed scenario into a :class:`~.driver.ClosureSetup`.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import BreachflowError, InputError
from ..scenario.config import register_section
from ..scenario.geometry import BreachGeometry, BreachScene, LeveeGeometry, typical_breach
from .criteria import EndCriteria
from .losses import breach_area
from .placement import POSITION_MODES, PlacementPlan


def demo_breach() -> BreachScene:
    """A small breach for the default run: a 3 m clay levee (crown 3 m, slopes 1V:2H) with water at the
    crest and a 12 m breach to the ground, 30 m of levee each side — the report's typical breach
    (SPEC §3) scaled down so a closure completes in minutes on a laptop."""
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
    metres; default the local transverse Mercator :data:`breachflow.hydro.crs.LOCAL_CRS`) and
    overrides of the scene: ground/flood elevations, extents, channel, ``polder_slope``, ``manning_n``.
    With ``terrain`` the table is a real site instead (:class:`breachflow.site.config.SiteTerrainSection`)."""

    preset: str = "demo_breach"
    crs: str | None = None
    overrides: dict = field(default_factory=dict)

    @classmethod
    def from_table(cls, table, ctx):
        if "terrain" in table:  # a real site: terrain, levee and breach from the user's files
            from ..site.config import SiteTerrainSection

            return SiteTerrainSection.from_table(table, ctx)
        return cls._preset_from_table(table, ctx)

    @classmethod
    def schema_keys(cls) -> dict:
        """The keys of both forms of ``[site]`` (preset scene, terrain site) for the scenario reference."""
        from ..scenario.reference import _Probe
        from ..site.config import SiteTerrainSection

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


#: warm re-solve of the ``swe`` solver: whole domain, or a window around the changed cells (hydro/window.py)
RESOLVE_MODES = ("full", "window")

#: solvers that take ingested snapshot files
SNAPSHOT_SOLVERS = ("snapshot", "snapshot_frozen", "nested")


@register_section("hydro")
@dataclass
class HydroSection:
    """``[hydro]``: ``solver`` (``swe`` | ``nested`` | ``snapshot_frozen`` | a plug-in; ``snapshot`` is the
    deprecated name of ``snapshot_frozen``), ``resolution``, ``order``, ``courant``,
    ``tolerance`` (relative rate, 1/s, of depth and discharge near the breach and of the breach
    discharge), ``t_max_initial`` / ``t_max`` (simulated time of the first and of each warm-started
    solve), ``monitor_radius`` (steady state is judged within this distance of the breach),
    ``snapshots`` (files for the ``snapshot_frozen`` / ``nested`` solvers: snapshot NetCDF from ``breachflow
    ingest``; ``nested`` also takes the model's own export files forming one snapshot — ADH ``.3dm`` +
    ``.dat`` + ``.bc``, a HEC-RAS ``.sdf`` or 6.x plan ``.hdf`` — read with ``open_snapshot``), ``window``
    (``[x0, x1, y0, y1]`` of the ``nested`` local model; default the breach ± (B/2 + 3 B) along the levee,
    ± 3 B across), ``threads`` (numba threads of one solve; default 1, the least CPU time; more threads
    can cut its wall time on free cores, README "Embedded shallow-water solver"). The default 2e-4 1/s puts the warm re-solves of the default scene within 0.37 % of
    their steady breach discharge (the former 2e-3 1/s and 60 s: 2.71 %; issue 12,
    ``python3 tasks.py bench steady``).

    ``resolve`` (``full`` | ``window``): a warm re-solve of the ``swe`` solver over the whole domain, or
    only in a window around the cells the remap changed, ``resolve_margin`` (default 2 B) beyond them and
    the breach, the rest frozen at the previous steady state, grown when the water level at its edge moves
    by more than ``resolve_edge_level`` (:mod:`breachflow.hydro.window`); ``resolve_far`` (``frozen`` |
    ``coarse``, :mod:`breachflow.hydro.window_far`) how the domain outside the window follows the pile,
    ``resolve_far_factor`` the coarsening of ``coarse`` (default 2). ``steady_average`` (default false): the
    ``swe`` solves (cold, warm, window) also accept the running mean of the breach discharge when its
    batch-means error is within the tolerance (``run_to_steady(average=True)``,
    :mod:`breachflow.hydro.steady_mean`; the state is then the time mean). ``refine`` (a length, with
    ``solver = "swe"``): a nested fine grid of that cell size around the breach (``window``, default the
    breach ± (B/2 + 3 B) along the levee, ± 3 B across) inside the coarse domain at ``resolution``: the
    coarse open-breach steady state is solved once and is the regional field of the ``nested`` local model
    (:mod:`breachflow.hydro.nested`) the closure runs on."""

    solver: str = "swe"
    resolution: float = 1.0
    order: int = 2
    courant: float = 0.45
    tolerance: float = 2e-4
    t_max_initial: float = 300.0
    t_max: float = 300.0
    monitor_radius: float = 20.0
    snapshots: list = field(default_factory=list)
    window: tuple | None = None
    threads: int = 1
    resolve: str = "full"
    resolve_margin: float | None = None
    resolve_edge_level: float = 0.03
    resolve_far: str = "frozen"
    resolve_far_factor: int = 2
    refine: float | None = None
    steady_average: bool = False

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"solver", "resolution", "order", "courant", "tolerance", "t_max_initial", "t_max",
                               "monitor_radius", "snapshots", "window", "threads", "resolve", "resolve_margin",
                               "resolve_edge_level", "resolve_far", "resolve_far_factor", "refine",
                               "steady_average"})
        out = cls(
            solver=ctx.raw(table, "solver", default="swe"),
            resolution=ctx.quantity(table, "resolution", "length", default="1 m", positive=True),
            order=ctx.raw(table, "order", types=(int,), default=2),
            courant=ctx.quantity(table, "courant", "dimensionless", default=0.45, default_unit="", positive=True),
            tolerance=ctx.quantity(table, "tolerance", "1/s", default="2e-4 1/s", positive=True),
            t_max_initial=ctx.quantity(table, "t_max_initial", "time", default="300 s", positive=True),
            t_max=ctx.quantity(table, "t_max", "time", default="300 s", positive=True),
            monitor_radius=ctx.quantity(table, "monitor_radius", "length", default="20 m", positive=True),
            snapshots=[ctx.base_dir / p for p in ctx.raw(table, "snapshots", types=(list,), default=[])],
            threads=ctx.raw(table, "threads", types=(int,), default=1),
            resolve=ctx.raw(table, "resolve", default="full"),
            resolve_edge_level=ctx.quantity(table, "resolve_edge_level", "length", default="0.03 m", positive=True),
            resolve_far=ctx.raw(table, "resolve_far", default="frozen"),
            resolve_far_factor=ctx.raw(table, "resolve_far_factor", types=(int,), default=2),
            steady_average=ctx.raw(table, "steady_average", types=(bool,), default=False),
        )
        if out.threads < 1:
            raise ctx.error(f"threads = {out.threads}: needs at least 1", "threads")
        out.refine = ctx.quantity(table, "refine", "length", positive=True)
        out.resolve_margin = ctx.quantity(table, "resolve_margin", "length", positive=True)
        if "window" in table:
            w = ctx.raw(table, "window", types=(list,))
            if len(w) != 4:
                raise ctx.error("window = [x0, x1, y0, y1] (lengths) of the nested local model", "window")
            vals = [ctx.quantity({"window": v}, "window", "length") for v in w]
            if not (vals[1] > vals[0] and vals[3] > vals[2]):
                raise ctx.error(f"window {w}: needs x0 < x1 and y0 < y1", "window")
            out.window = tuple(vals)
        if out.resolve not in RESOLVE_MODES:
            raise ctx.error(f"resolve = {out.resolve!r}; use one of {list(RESOLVE_MODES)}", "resolve")
        from ..hydro.window_far import far_fields

        if out.resolve_far not in far_fields:
            raise ctx.error(f"resolve_far = {out.resolve_far!r}; use one of {far_fields.available()}", "resolve_far")
        if out.resolve_far_factor < 2:
            raise ctx.error(f"resolve_far_factor = {out.resolve_far_factor}: needs at least 2", "resolve_far_factor")
        if out.refine is not None:
            if out.solver != "swe":
                raise ctx.error(f"refine (a nested fine grid around the breach) needs solver = 'swe', not {out.solver!r}",
                                "refine")
            if not out.refine < out.resolution:
                raise ctx.error(f"refine = {out.refine:g} m must be finer than resolution = {out.resolution:g} m", "refine")
        if out.solver in SNAPSHOT_SOLVERS and not out.snapshots:
            raise ctx.error(f"solver {out.solver!r} needs snapshots = [files]", "solver")
        if out.solver == "snapshot":
            import warnings

            warnings.warn(f"{ctx.path or '<scenario>'}: [hydro] solver = 'snapshot' is deprecated; it is 'snapshot_frozen' "
                          "(the ingested flow served unchanged, it does not respond to the pile)", DeprecationWarning,
                          stacklevel=2)
        return out


@register_section("dem")
@dataclass
class DemSection:
    """``[dem]``: material (``kn``, ``ks``, ``friction``, ``rolling_friction``, ``adhesion``, ``restitution``, ``global_damping``)
    and run control (``integrator``, ``e_tol``, ``max_time`` per cycle (safety cap), ``rest_speed``, ``rest_time``,
    ``rest_rule`` (``window`` | ``speed``: which masses are the pile at the cap, :mod:`~breachflow.cycle.rest`),
    ``record_interval``, ``sleeping``, ``stability_time``)."""

    values: dict = field(default_factory=dict)

    #: material defaults of a closure run (SI); the rest of the defaults are :class:`~.driver.DemSettings`'
    MATERIAL_DEFAULTS = {"kn": 2.0e7, "friction": 0.6, "rolling_friction": 0.3, "adhesion": 0.0}

    @classmethod
    def schema_defaults(cls) -> dict:
        """Default of every key (SI values with their unit), for the scenario reference."""
        from ..units import SI_UNITS
        from .driver import DemSettings

        d = DemSettings()
        vals = {**{k: getattr(d, k) for k in cls.KINDS if hasattr(d, k)}, **cls.MATERIAL_DEFAULTS,
                "integrator": d.integrator, "sleeping": d.sleeping, "rest_rule": d.rest_rule}
        out = {}
        for k, v in vals.items():
            unit = SI_UNITS.get(cls.KINDS.get(k, ""), "")
            out[k] = v if isinstance(v, (bool, str)) or not unit else f"{v:g} {unit}"
        out["ks"] = "kn (Material default: equal stiffnesses, as the report)"
        return out

    KINDS = {"kn": "stiffness", "ks": "stiffness", "friction": "dimensionless", "rolling_friction": "dimensionless",
             "adhesion": "force",
             "restitution": "dimensionless", "global_damping": "damping", "e_tol": "length", "max_time": "time",
             "rest_speed": "speed", "record_interval": "time", "stability_time": "time", "rest_time": "time"}

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, set(cls.KINDS) | {"integrator", "sleeping", "rest_rule"})
        vals = {k: ctx.quantity(table, k, kind, default_unit="" if kind == "dimensionless" else None, nonnegative=True)
                for k, kind in cls.KINDS.items() if k in table}
        if "integrator" in table:
            vals["integrator"] = ctx.raw(table, "integrator")
        if "sleeping" in table:
            vals["sleeping"] = ctx.raw(table, "sleeping", types=(bool,))
        if "rest_rule" in table:
            from .rest import REST_RULES

            vals["rest_rule"] = ctx.raw(table, "rest_rule")
            try:
                REST_RULES.get(vals["rest_rule"])
            except InputError as exc:
                raise ctx.error(str(exc), "rest_rule") from None
        return cls(vals)


@register_section("fluid")
@dataclass
class FluidSection:
    """``[fluid]``: ``drag_law`` (registry name), ``sampling`` (``bilinear`` | ``neighbourhood``), ``xi``,
    ``velocity_profile`` (``log`` (default) | ``power`` | ``uniform``, :mod:`breachflow.fluid.profile`;
    the log law follows Shields' depth dependence in the stone-stability validation, README) and
    ``roughness`` (k_s of the log law; default from the site's Manning n)."""

    drag_law: str = "report"
    sampling: str = "bilinear"
    xi: float = 0.5
    velocity_profile: str = "log"
    roughness: float | None = None

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"drag_law", "sampling", "xi", "velocity_profile", "roughness"})
        out = cls(ctx.raw(table, "drag_law", default="report"), ctx.raw(table, "sampling", default="bilinear"),
                  ctx.quantity(table, "xi", "dimensionless", default=0.5, default_unit="", nonnegative=True),
                  ctx.raw(table, "velocity_profile", default="log"),
                  ctx.quantity(table, "roughness", "length", default=None, default_unit="m", positive=True))
        from ..fluid.drag import get_drag_law
        from ..fluid.profile import PROFILES

        if out.velocity_profile not in PROFILES:
            raise ctx.error(f"velocity_profile must be one of {sorted(PROFILES)}", "velocity_profile")

        try:
            get_drag_law(out.drag_law)
        except BreachflowError as exc:
            raise ctx.error(str(exc), "drag_law") from None
        return out


@register_section("placement")
@dataclass
class PlacementSection:
    """``[placement]``: see :class:`~.placement.PlacementPlan` (``diameter``, ``density``, ``batch``,
    ``positions`` (``line`` | ``zone`` | ``list`` | ``vertical`` | ``horizontal``, :mod:`~.strategies`),
    ``start``/``stop``/``zone``/``points``, ``release_height``, ``rate``)."""

    plan: PlacementPlan

    @classmethod
    def schema_keys(cls) -> dict:
        """The keys :meth:`~breachflow.cycle.placement.PlacementPlan.from_config` reads, their kinds and the plan's defaults."""
        from dataclasses import MISSING, fields

        from ..scenario.reference import quantity_schema
        from ..units import SI_UNITS

        out = {}
        for f in fields(PlacementPlan):
            default = f.default if f.default is not MISSING else None
            kind = PlacementPlan.KEY_KINDS.get(f.name)
            if kind is None:
                out[f.name] = {"type": "integer" if f.name == "batch" else "string"}
                if default is not None:
                    out[f.name]["default"] = default
                if f.name == "positions":
                    out[f.name]["enum"] = list(POSITION_MODES)
                continue
            unit = SI_UNITS.get(kind, kind)
            if f.name == "rate":
                default = f"{default * 3600:g} 1/hr"
            elif isinstance(default, tuple):
                default = [f"{v:g} {unit}" for v in default]
            elif default is not None:
                default = f"{default:g} {unit}"
            out[f.name] = quantity_schema(kind, default=default, positive=f.name in ("diameter", "density", "rate"),
                                          nonnegative=f.name == "release_height",
                                          default_unit="m" if f.name in ("start", "stop", "zone", "points") else None)
        return out

    @classmethod
    def from_table(cls, table, ctx):
        try:
            return cls(PlacementPlan.from_config(table))
        except (BreachflowError, TypeError, ValueError) as exc:
            key = next((k for k in table if k in str(exc)), None)
            raise ctx.error(str(exc), key) from None


@register_section("criteria")
@dataclass
class CriteriaSection:
    """``[criteria]``: ``mode`` (``any``|``all``), ``max_cycles`` and thresholds by criterion name."""

    criteria: EndCriteria

    @classmethod
    def schema_keys(cls) -> dict:
        """``mode``, ``max_cycles`` and one threshold per registered criterion (its kind and unit)."""
        from ..scenario.reference import quantity_schema
        from .criteria import criteria as registry

        out = {"mode": {"type": "string", "enum": ["any", "all"], "default": "any"},
               "max_cycles": {"type": "integer", "default": 50}}
        for name in registry.available():
            c = registry.get(name)
            spec = quantity_schema(c.kind, default_unit="" if c.kind == "dimensionless" else None, nonnegative=True,
                                   sweep=False)
            spec["anyOf"].append({"type": "object", "description": "keyword arguments of the criterion"})
            spec["description"] = f"threshold ({c.compare} it counts as met; unit {c.units}) {c.description}".strip()
            out[name] = spec
        return out

    @classmethod
    def from_table(cls, table, ctx):
        try:
            return cls(EndCriteria.from_config(table))
        except (BreachflowError, TypeError, ValueError) as exc:
            key = next((k for k in table if k in str(exc)), None)
            raise ctx.error(str(exc), key) from None


@register_section("closure")
@dataclass
class ClosureSection:
    """``[closure]``: ``remap`` (``porous``, the default: a leaky rock-fill pile | ``raised_bed`` |
    ``no_flow``), ``seed``, ``porous_law`` (``ergun`` | ``van_gent``: Forchheimer coefficients of a porous
    pile), ``area`` (the breach area ``[x0, x1, y0, y1]`` outside which masses count as carried away
    and where ``max_speed`` judges the flow; default from the scene, see
    :mod:`~breachflow.cycle.losses`), ``loss_limit`` (fraction of a cycle's tonnage whose loss ends the run with a
    "not closable" verdict, default 0.5), ``pile_sampling`` (how the pile enters ``raised_bed`` / ``no_flow``:
    ``centre``, the default: the sphere top above each cell centre | ``cell_average``: the cell average of
    the pile top, blocked where it stands above the water over half the cell, :mod:`~breachflow.cycle.remap`)."""

    remap: str = "porous"
    seed: int = 0
    area: tuple | None = None
    loss_limit: float = 0.5
    porous_law: str = "ergun"
    pile_sampling: str = "centre"

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"remap", "seed", "area", "loss_limit", "porous_law", "pile_sampling"})
        area = None
        if "area" in table:
            val = ctx.raw(table, "area", types=(list,))
            if len(val) != 4:
                raise ctx.error(f"area must be [x0, x1, y0, y1], got {val!r}", "area")
            area = tuple(float(v) for v in ctx.quantity({"area": val}, "area", "length", dim="area").values)
            if not (area[0] < area[1] and area[2] < area[3]):
                raise ctx.error(f"area must be [x0, x1, y0, y1] with x0 < x1 and y0 < y1, got {val!r}", "area")
        loss = ctx.quantity(table, "loss_limit", "dimensionless", default=0.5, default_unit="", positive=True)
        out = cls(ctx.raw(table, "remap", default="porous"), ctx.raw(table, "seed", types=(int,), default=0),
                  area, float(loss), ctx.raw(table, "porous_law", default="ergun"),
                  ctx.raw(table, "pile_sampling", default="centre"))
        from ..hydro.swe.porous import FORCHHEIMER_LAWS
        from .remap import PILE_SAMPLINGS, REMAP_MODES

        if out.pile_sampling not in PILE_SAMPLINGS:
            raise ctx.error(f"pile_sampling must be one of {PILE_SAMPLINGS}", "pile_sampling")

        if out.remap not in REMAP_MODES:
            raise ctx.error(f"remap must be one of {REMAP_MODES}", "remap")
        if out.porous_law not in FORCHHEIMER_LAWS:
            raise ctx.error(f"porous_law must be one of {sorted(FORCHHEIMER_LAWS)}", "porous_law")
        return out


def closure_setup(scenario, *, overrides: dict | None = None):
    """Build the :class:`~.driver.ClosureSetup` of a parsed scenario (missing sections take defaults)."""
    from ..dem import Material
    from ..hydro.solvers import get_solver
    from ..hydro.terrain import breach_domain
    from .driver import ClosureSetup, DemSettings

    site = scenario.get("site") or SiteSection()
    hydro = scenario.get("hydro") or HydroSection()
    attrs = {}
    metadata = {}
    if hasattr(site, "build"):  # a terrain site (breachflow.site)
        # the embedded, nested and frozen-snapshot solvers run on a grid along the levee (any direction;
        # a frozen field is served on it); a plug-in's field stays on the CRS axes
        built = site.build(hydro.resolution, align=hydro.solver in ("swe", "nested", "snapshot", "snapshot_frozen"))
        dom = built.domain
        (xc, yc), half = built.centre, 0.5 * built.breach.length
        flood_level, bottom = built.flood_level, built.breach.bottom
        metadata["site"] = _jsonable(built.report)
        attrs.update(site_terrain=str(built.terrain.path.name), site_levee=str(built.levee.source).split("/")[-1],
                     site_breach_centre=f"{xc:.3f} {yc:.3f}", site_flood_side=built.report["flood_side"])
    else:
        levee = scenario["levee"].geometry if "levee" in scenario else None
        breach = None
        if "breach" in scenario and scenario["breach"].length is not None:
            b = scenario["breach"]
            base = site.scene().breach
            breach = BreachGeometry(length=float(b.length), depth=float(b.depth) if b.depth is not None else base.depth,
                                    wall_slope=float(b.wall_slope) if b.wall_slope is not None else base.wall_slope,
                                    scour_depth=float(b.scour_depth) if b.scour_depth is not None else base.scour_depth)
        scene = site.scene(levee, breach)
        built = None
        dom = breach_domain(scene, hydro.resolution)
        dom.crs_wkt = _crs_wkt(site.crs)
        (xc, yc), half = (0.0, 0.0), 0.5 * scene.breach.length
        flood_level = scene.flood_water_elevation
        bottom = scene.ground_elevation + scene.levee.height - scene.breach.depth - scene.breach.scour_depth
    nested = None
    if hydro.solver == "nested" or hydro.refine is not None:
        from ..hydro.nested import NestedSolver, breach_window

        fine = hydro.resolution if hydro.refine is None else hydro.refine
        regional = hydro.snapshots
        if hydro.refine is not None:  # the coarse open-breach steady state is the regional field
            if built is not None and built.stage is not None:
                raise InputError("[hydro] refine: a stage hydrograph of the site is not supported with a nested grid")
            Xc, Yc = np.meshgrid(dom.x, dom.y)
            reg_c = (np.abs(Xc - xc) <= half + hydro.monitor_radius) & (np.abs(Yc - yc) <= hydro.monitor_radius + half)
            regional = [_WarmStartSWE(hydro, reg_c, section=(xc - half, xc + half, yc)).cold.solve(dom)]
            metadata.update(refine_coarse_resolution=hydro.resolution, refine_resolution=hydro.refine)
        # an ingested field is on the CRS axes: the local grid of a rotated site samples it in its frame
        # (a refine's coarse steady state is already on the site's grid)
        frame = built.frame if built is not None and hydro.refine is None and built.frame.rotated else None
        window, spacing = breach_window(xc, yc, 2.0 * half, fine)
        if hydro.window is not None:
            if frame is not None:
                raise InputError(f"[hydro] window = {list(hydro.window)} is a box on the CRS axes, but the grid of this "
                                 f"site runs along the levee ({frame.angle_deg:.1f}° from the CRS x axis); leave it out "
                                 f"(the default window is the breach ± (B/2 + 3 B) along the levee and ± 3 B across)")
            window, spacing = hydro.window, fine
        nested = NestedSolver(regional, window, spacing, manning=float(np.mean(dom.manning)),
                              order=hydro.order, courant=hydro.courant, tolerance=hydro.tolerance,
                              t_max_initial=hydro.t_max_initial, t_max=hydro.t_max, frame=frame)
        if nested.domain.crs_wkt is None:  # regional files without a CRS (e.g. ADH without its .prj): the site's
            nested.domain.crs_wkt = dom.crs_wkt
        elif built is not None and hydro.refine is None:
            _check_regional_crs(nested.domain.crs_wkt, dom.crs_wkt, nested.source, built.terrain.path)
        if hydro.refine is not None:
            nested.source = f"breachflow swe steady state at {hydro.resolution:g} m cells (coarse domain)"
            nested.section = (xc - half, xc + half, yc)
        dom = nested.domain
        metadata.update(hydro_mode="nested", nested_window=list(nested.window), nested_regional=nested.source,
                        nested_cells=list(dom.shape))
    X, Y = np.meshgrid(dom.x, dom.y)
    region = (np.abs(X - xc) <= half + hydro.monitor_radius) & (np.abs(Y - yc) <= hydro.monitor_radius + half)
    if nested is not None:
        nested.region = region
        solver = nested
    elif hydro.solver == "swe":
        solver = _WarmStartSWE(hydro, region, section=(xc - half, xc + half, yc))
        if built is not None and built.stage is not None:
            solver = _StageSolver(solver, built)
    else:
        import warnings

        with warnings.catch_warnings():  # the deprecation was reported where the scenario was parsed
            warnings.simplefilter("ignore", DeprecationWarning)
            turned = built.frame if built is not None and built.frame.rotated else None
            solver = (get_solver(hydro.solver, snapshots=hydro.snapshots, domain=dom, frame=turned)
                      if hydro.solver in ("snapshot", "snapshot_frozen") else get_solver(hydro.solver))
    if getattr(solver, "responds_to_pile", True) is False:
        from ..errors import BreachflowWarning
        from ..hydro.solvers import FROZEN_NOTE

        attrs.update(hydro_mode=getattr(solver, "mode", hydro.solver), flow_responds_to_pile=np.int32(0),
                     hydro_note=FROZEN_NOTE)
        metadata.update(hydro_mode=getattr(solver, "mode", hydro.solver), flow_responds_to_pile=False)
        import warnings

        warnings.warn(f"[hydro] solver = {hydro.solver!r}: {FROZEN_NOTE}", BreachflowWarning, stacklevel=2)
    dem_vals = dict((scenario.get("dem") or DemSection()).values)
    mat_keys = {k: dem_vals.pop(k) for k in ("kn", "ks", "friction", "rolling_friction", "adhesion") if k in dem_vals}
    dem_kw = {}
    if "global_damping" in dem_vals:
        dem_kw["global_damping"] = dem_vals.pop("global_damping")
    mat = {**DemSection.MATERIAL_DEFAULTS, **mat_keys}
    material = Material(density=2650.0, kn=mat["kn"], ks=mat.get("ks"), friction=mat["friction"],
                        adhesion=mat["adhesion"], rolling_friction=mat["rolling_friction"])
    fluid = scenario.get("fluid") or FluidSection()
    dem = DemSettings(material=material, drag_law=fluid.drag_law, sampling=fluid.sampling, xi=fluid.xi,
                      velocity_profile=fluid.velocity_profile, roughness=fluid.roughness,
                      **dem_vals, **dem_kw)
    closure = scenario.get("closure") or ClosureSection()
    placement = scenario["placement"].plan if "placement" in scenario else PlacementPlan(
        diameter=(1.4, 1.6), batch=4, positions="line", start=(xc - half + 0.5, yc), stop=(xc + half - 0.5, yc))
    if placement.positions not in ("zone", "list") and placement.start == placement.stop == (0.0, 0.0):
        # no line given (line, vertical, horizontal): across the breach along the levee centreline, one
        # radius in from the walls (the breach heads)
        r = 0.5 * placement.diameter[1]
        placement.start, placement.stop = (xc - half + r, yc), (xc + half - r, yc)
    elif built is not None and built.frame.rotated:
        placement = _placement_to_grid(placement, built.frame)
    if built is not None and built.frame.rotated and closure.area is not None:
        raise InputError(f"[closure] area = {list(closure.area)} is a box on the CRS axes, but the grid of this site "
                         f"runs along the levee ({built.frame.angle_deg:.1f}° from the CRS x axis); leave it out "
                         f"(the breach area is then the whole domain)")
    # without [criteria]: a porous pile is closed when the overflow has stopped and the seepage is below 30 %
    # of the open breach's discharge (its toe stays fast); an impervious one when the flow in the breach is slow
    criteria = scenario["criteria"].criteria if "criteria" in scenario else EndCriteria.from_config(
        {"mode": "all", "max_cycles": 20, "overflow_discharge": "0.5 m^3/s", "seepage_fraction": 0.3}
        if closure.remap == "porous" else {"mode": "any", "max_cycles": 20, "max_speed": "0.5 m/s"})
    if isinstance(solver, _StageSolver):
        solver.plan = placement
    setup = ClosureSetup(domain=dom, solver=solver, placement=placement, criteria=criteria, dem=dem,
                         remap_mode=closure.remap, pile_sampling=closure.pile_sampling, porous_law=closure.porous_law, seed=closure.seed,
                         breach_x=(xc - half, xc + half), levee_y=yc,
                         flood_level=flood_level, bottom=bottom, name=scenario.name, attrs=attrs, metadata=metadata,
                         area=closure.area or (breach_area(scene, placement.diameter[1]) if built is None else None),
                         loss_limit=closure.loss_limit, frame=built.frame if built is not None else None)
    for k, v in (overrides or {}).items():
        setattr(setup, k, v)
    from .sanity import check_setup

    setup.warnings = check_setup(setup)
    return setup


def _placement_to_grid(placement, frame):
    """The release positions of *placement* (given in the site CRS) in the grid coordinates of a rotated
    site (:class:`~breachflow.site.frame.GridFrame`); a new plan, the scenario's is left as it is."""
    if placement.positions == "zone":
        raise InputError(f"[placement] zone = {list(placement.zone)} is a box on the CRS axes, but the grid of this "
                         f"site runs along the levee ({frame.angle_deg:.1f}° from the CRS x axis); give positions = "
                         f"'line' (start, stop) or 'list' (points) in the site CRS instead")
    to_grid = lambda p: tuple(float(v) for v in frame.to_grid(p[0], p[1]))
    return replace(placement, start=to_grid(placement.start), stop=to_grid(placement.stop),
                   points=[to_grid(p) for p in placement.points])


class _WarmStartSWE:
    """The ``swe`` solver with a longer time limit for the first (cold) solve than for warm starts; the
    steady state is judged on depth and discharge in *region* and on the breach discharge (*section*
    ``(x0, x1, y)``, the levee centreline across the breach)."""

    def __init__(self, hydro: HydroSection, region, section=None):
        from ..hydro.solvers import get_solver

        kw = dict(order=hydro.order, courant=hydro.courant, tolerance=hydro.tolerance, region=region,
                  section=section, threads=hydro.threads, average=hydro.steady_average)
        self.cold = get_solver("swe", t_max=hydro.t_max_initial, **kw)
        self.warm = get_solver("swe", t_max=hydro.t_max, **kw)
        self.window = None
        if hydro.resolve == "window":
            from ..hydro.window import WindowResolver

            self.window = WindowResolver(self.warm, margin=hydro.resolve_margin, edge_level=hydro.resolve_edge_level,
                                         far=hydro.resolve_far,
                                         far_factor=hydro.resolve_far_factor if hydro.resolve_far == "coarse" else None)

    def solve(self, domain, obstacles=None, initial=None):
        if initial is None:
            return self.cold.solve(domain, obstacles=obstacles, initial=initial)
        return (self.window or self.warm).solve(domain, obstacles=obstacles, initial=initial)


class _StageSolver:
    """A solver whose flood-side level follows a stage hydrograph: solve ``k`` (0 the initial one) uses the
    stage at the operation time of cycle ``k`` (quasi-steady: each cycle's flow is the steady state at the
    level of the moment its masses are placed)."""

    def __init__(self, inner, site, plan=None):
        self.inner, self.site, self.plan, self.calls = inner, site, plan, 0

    def solve(self, domain, obstacles=None, initial=None):
        t = 0.0 if self.plan is None else self.plan.operation_time(self.calls * self.plan.batch)
        self.calls += 1
        level = self.site.level_at(t)
        from ..hydro.terrain import _copy_spacing

        d = replace(domain, boundaries=self.site.with_level(level).boundaries)
        _copy_spacing(domain, d)
        return self.inner.solve(d, obstacles=obstacles, initial=initial)


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def _crs_wkt(crs: str | None) -> str:
    """WKT of the site's CRS (``EPSG:nnnn``, WKT, PROJ; in metres: site coordinates are metres); the
    default is the documented local projected CRS :data:`~breachflow.hydro.crs.LOCAL_CRS`."""
    from ..hydro.crs import local_crs_wkt, resolve_crs

    if not crs:
        return local_crs_wkt()
    return resolve_crs(crs, where="[site] crs", data_unit="m")


def _check_regional_crs(regional_wkt: str, site_wkt: str, regional_name: str, terrain_path) -> None:
    """A regional model in another CRS than the site's terrain would put the breach in the wrong place:
    refuse it. Both CRSs must be metric for the comparison (an ingested model in feet was converted to
    metres at ingest, but its CRS still names feet: not compared)."""
    from pyproj import CRS

    try:
        reg, site = CRS.from_user_input(regional_wkt), CRS.from_user_input(site_wkt)
    except Exception:  # noqa: BLE001 - an unreadable CRS is reported where it is read, not here
        return
    metric = all(c.axis_info and all(a.unit_name in ("metre", "meter") for a in c.axis_info) for c in (reg, site))
    if metric and not reg.equals(site, ignore_axis_order=True):
        raise InputError(f"[hydro] snapshots: the regional model ({regional_name}) is in {reg.name!r} but the "
                         f"site's terrain ({terrain_path}) is in {site.name!r}; re-project one of them (e.g. "
                         f"`gdalwarp -t_srs` for the terrain) so both use the same CRS")
