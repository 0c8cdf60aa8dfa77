"""The district file of a breach atlas: levee, terrain, flood, polder, breach growth, closure methods.

A district TOML (every quantity with units; paths relative to the file)::

    [district]
    name = "example district"
    terrain = "terrain.tif"          # GeoTIFF / ESRI ASCII (.asc + .prj) / NetCDF DEM
    levee = "levee.geojson"          # centreline: GeoJSON / GeoPackage / shapefile
    crs = "EPSG:26915"               # only when the terrain has none (must agree when it has one)
    flood_side = "left"              # of the levee line's direction
    spacing = "200 m"                # candidate breaches along the line
    points = ["1250 m", "3020 m"]    # and at these chainages

    [flood]
    level = "5.0 m"                  # peak stage (same datum as the terrain)
    fall_rate = "2 cm/h"             # linear flood (report §2.4); or preset = "..." ; rise_rate optional

    [polder]
    area = "4900 ha"                 # the protected area behind the levee
    inundation_depth = "1 m"         # closure-window criterion t_I
    pump_capacity = "0 m^3/s"

    [breach]
    growth = "verheij_clay"          # a growth equation (report eqs. 2.2-2.8)
    max_length = "von_thun_gillette"   # a maximum-length equation (2.9-2.11) or a length
    development_time = "24 h"        # time from breaching to the start of the closure
    flow = "swe"                     # open-breach discharge: "swe" (embedded solver, local domain) or "weir"
    resolution = "8 m"               # of the local SWE domain
    manning_n = 0.03

    [rock]
    density = "2650 kg/m^3"
    porosity = 0.4

    [methods.split_barge]            # one table per closure method: a delivery method of the closure run
    capacity = "1000 t/h"            # (split_barge, barge_crane, end_dumping, cableway, helicopter) with its
    working_hours = "24 h"           # defaults overridden, or your own (method = NAME not registered: give
    mobilisation = "24 h"            # capacity); mobilisation: until the first load is dumped

:func:`load_district` checks every key before anything runs; errors name the file, line and key.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError, ParseError
from ..scenario.config import SectionContext

DISTRICT_KEYS = {"name", "description", "terrain", "levee", "crs", "terrain_units", "flood_side", "spacing", "points",
                 "margin"}
FLOOD_KEYS = {"level", "fall_rate", "rise_rate", "preset", "duration"}
POLDER_KEYS = {"area", "inundation_depth", "pump_capacity"}
BREACH_KEYS = {"growth", "max_length", "development_time", "flow", "resolution", "manning_n", "t_max", "tolerance"}
ROCK_KEYS = {"density", "porosity", "side_slope"}
METHOD_KEYS = {"method", "capacity", "working_hours", "mobilisation", "description"}
DETAILED_KEYS = {"worst", "replicates", "scenario"}
TOP_LEVEL = {"district", "flood", "polder", "breach", "rock", "methods", "detailed"}
FLOW_MODELS = ("swe", "weir")


@dataclass(frozen=True)
class ClosureMethod:
    """A closure method of the atlas: a delivery method of the closure run (:mod:`breachflow.cycle.delivery`:
    capacity, working hours, wind limit, units) and the mobilisation time (s) until its first load is dumped."""

    name: str
    delivery: object
    mobilisation: float = 0.0
    description: str = ""

    @property
    def capacity(self) -> float:
        return self.delivery.capacity

    @property
    def working_hours(self) -> float:
        return self.delivery.working_hours

    def duration(self, tonnage_kg: float) -> float:
        """Time (s) from the start of mobilisation until *tonnage_kg* is in place: the mobilisation, then the
        working time spread over the method's working hours of each day (the closure run's clock,
        :class:`~breachflow.cycle.delivery.DeliveryClock`, without a wind record)."""
        from ..cycle.delivery import DeliveryClock

        return self.mobilisation + DeliveryClock(self.delivery).time_after(self.delivery.work_time(tonnage_kg))


@dataclass(frozen=True)
class District:
    """A parsed district file (SI floats; paths absolute)."""

    path: Path | None
    name: str
    description: str
    terrain: Path
    levee: Path
    crs: str | None
    terrain_units: str | None
    flood_side: str
    spacing: float
    points: tuple[float, ...]
    margin: float
    flood_level: float
    fall_rate: float | None
    rise_rate: float | None
    preset: str | None
    flood_duration: float | None
    polder_area: float
    inundation_depth: float
    pump_capacity: float
    growth: str
    max_length: object
    development_time: float
    flow: str
    resolution: float
    manning_n: float
    t_max: float
    tolerance: float
    rock_density: float
    porosity: float
    side_slope: float
    methods: tuple[ClosureMethod, ...] = field(default_factory=tuple)
    #: the ``[detailed]`` table (worst, replicates, scenario path), or None: screening only
    detailed: dict | None = None


def load_district(path) -> District:
    """Read and check a district TOML (see the module docstring)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the district file ({exc.strerror})") from None
    return parse_district(text, path)


def parse_district(text: str, path: Path | None = None) -> District:
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParseError(f"not valid TOML: {exc}", path=path) from None
    for key in table:
        if key not in TOP_LEVEL:
            raise ParseError(f"unknown section [{key}] (allowed: {', '.join(sorted(TOP_LEVEL))})", path=path)
    ctx = lambda name: SectionContext(path, text, name)  # noqa: E731
    d, c = table.get("district", {}), ctx("district")
    c.check_keys(d, DISTRICT_KEYS)
    for req in ("terrain", "levee"):
        c.raw(d, req, required=True)
    side = c.raw(d, "flood_side", default="left")
    if side not in ("left", "right"):
        raise c.error(f"expected 'left' or 'right' (of the levee line's direction), got {side!r}", "flood_side")
    points = c.raw(d, "points", types=(list,), default=[])
    pts = tuple(c.quantity({"points": p}, "points", "length", nonnegative=True) for p in points)
    spacing = c.quantity(d, "spacing", "length", default="200 m", positive=True)

    f, cf = table.get("flood", {}), ctx("flood")
    cf.check_keys(f, FLOOD_KEYS)
    level = cf.quantity(f, "level", "length", required=True)
    preset = cf.raw(f, "preset")
    fall = cf.quantity(f, "fall_rate", "rate", positive=True)
    if fall is None and preset is None:
        raise cf.error("give fall_rate (a linear flood) or preset (a flood of the report's presets)", None)

    p, cp = table.get("polder", {}), ctx("polder")
    cp.check_keys(p, POLDER_KEYS)

    b, cb = table.get("breach", {}), ctx("breach")
    cb.check_keys(b, BREACH_KEYS)
    flow = cb.raw(b, "flow", default="swe")
    if flow not in FLOW_MODELS:
        raise cb.error(f"unknown flow model {flow!r}; use one of {', '.join(FLOW_MODELS)}", "flow")
    max_length = b.get("max_length", "von_thun_gillette")
    if not isinstance(max_length, str):
        raise cb.error("expected a maximum-length equation name or a length with units", "max_length")

    from ..scenario.growth import growth_equations, max_length_equations

    growth = cb.raw(b, "growth", default="verheij_clay")
    if growth not in growth_equations:
        raise cb.error(f"unknown growth equation {growth!r}; available: {', '.join(growth_equations.available())}",
                       "growth")
    if max_length not in max_length_equations:
        try:
            max_length = f"{cb.quantity(b, 'max_length', 'length', positive=True)} m"
        except ParseError:
            raise cb.error(f"{max_length!r} is neither a maximum-length equation "
                           f"({', '.join(max_length_equations.available())}) nor a length", "max_length") from None

    r, cr = table.get("rock", {}), ctx("rock")
    cr.check_keys(r, ROCK_KEYS)
    porosity = float(cr.raw(r, "porosity", types=(int, float), default=0.4))
    if not 0.0 <= porosity < 1.0:
        raise cr.error(f"porosity must be in [0, 1), got {porosity}", "porosity")

    methods = []
    mtab = table.get("methods", {})
    if not isinstance(mtab, dict) or not mtab:
        raise ParseError("[methods]: give at least one closure method table, e.g. [methods.split_barge] "
                         "capacity = \"1000 t/h\"", path=path)
    from ..cycle.delivery import DeliveryMethod, delivery_method, delivery_methods

    for name, m in mtab.items():
        cm = ctx(f"methods.{name}")
        if not isinstance(m, dict):
            raise cm.error("expected a table of capacity, working_hours, mobilisation")
        cm.check_keys(m, METHOD_KEYS)
        kind = cm.raw(m, "method", default=name)
        over = {}
        if "capacity" in m:
            over["capacity"] = cm.quantity(m, "capacity", "kg/s", positive=True)
        if "working_hours" in m:
            over["working_hours"] = cm.quantity(m, "working_hours", "time", positive=True)
            if over["working_hours"] > 86400.0:
                raise cm.error(f"working_hours is per day: at most 24 h, got {over['working_hours'] / 3600:g} h",
                               "working_hours")
        try:
            if kind in delivery_methods:
                delivery = delivery_method(kind, **over)
            elif "capacity" in m:
                delivery = DeliveryMethod(name=name, **over)
            else:
                raise cm.error(f"{kind!r} is not a delivery method ({', '.join(delivery_methods.available())}); a "
                               f"method of your own needs capacity = \"... t/h\"", "method" if "method" in m else None)
        except InputError as exc:
            if isinstance(exc, ParseError):
                raise
            raise cm.error(str(exc)) from None
        methods.append(ClosureMethod(
            name=name, delivery=delivery,
            mobilisation=cm.quantity(m, "mobilisation", "time", default="0 h", nonnegative=True),
            description=cm.raw(m, "description", default="")))

    detailed = None
    if "detailed" in table:
        t, ct = table["detailed"], ctx("detailed")
        ct.check_keys(t, DETAILED_KEYS)
        worst = t.get("worst", 5)
        if not (worst == "all" or (isinstance(worst, int) and not isinstance(worst, bool) and worst >= 1)):
            raise ct.error(f"expected a positive integer or \"all\", got {worst!r}", "worst")
        reps = t.get("replicates", 4)
        if not (isinstance(reps, int) and not isinstance(reps, bool) and reps >= 2):
            raise ct.error(f"expected an integer of at least 2 (P(closure) and its interval are counted over the "
                           f"replicates), got {reps!r}", "replicates")
        detailed = {"worst": worst, "replicates": reps, "scenario": ct.file(t, "scenario")}

    base = path.parent if path is not None else Path.cwd()
    return District(
        path=path, name=c.raw(d, "name", default=path.stem if path else "district"),
        description=c.raw(d, "description", default=""),
        terrain=c.file(d, "terrain"), levee=c.file(d, "levee") or base, crs=c.raw(d, "crs"),
        terrain_units=c.raw(d, "terrain_units"), flood_side=side, spacing=spacing, points=pts,
        margin=c.quantity(d, "margin", "length", default="100 m", nonnegative=True),
        flood_level=level, fall_rate=fall, rise_rate=cf.quantity(f, "rise_rate", "rate", positive=True),
        preset=preset, flood_duration=cf.quantity(f, "duration", "time", positive=True),
        polder_area=cp.quantity(p, "area", "area", required=True, positive=True),
        inundation_depth=cp.quantity(p, "inundation_depth", "length", default="1 m", positive=True),
        pump_capacity=cp.quantity(p, "pump_capacity", "discharge", default="0 m^3/s", nonnegative=True),
        growth=growth, max_length=max_length,
        development_time=cb.quantity(b, "development_time", "time", default="24 h", nonnegative=True),
        flow=flow, resolution=cb.quantity(b, "resolution", "length", default="8 m", positive=True),
        manning_n=cb.quantity(b, "manning_n", "manning", default=0.03, default_unit="s/m**(1/3)", positive=True),
        t_max=cb.quantity(b, "t_max", "time", default="1200 s", positive=True),
        tolerance=cb.quantity(b, "tolerance", "1/s", default="2e-3 1/s", default_unit="1/s", positive=True),
        rock_density=cr.quantity(r, "density", "density", default="2650 kg/m^3", positive=True),
        porosity=porosity, side_slope=float(cr.raw(r, "side_slope", types=(int, float), default=1.5)),
        methods=tuple(methods), detailed=detailed,
    )
