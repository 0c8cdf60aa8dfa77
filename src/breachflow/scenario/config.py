"""Scenario files: TOML with units in the values, strict keys, one section class per table.

A scenario file is a set of tables; each table is parsed by the section class registered under its name
(registry ``breachflow.scenario_sections``). Built-in sections: ``[scenario]``, ``[flood]``, ``[polder]``,
``[breach]``, ``[levee]``, ``[wind]``. Unknown tables and keys are errors naming the file and line.
Quantities are strings with units (``"2.8 m"``, ``"40 cm/hr"``, ``"800 ha"``); a list of them sweeps a
dimension named after the key. Relative paths are relative to the scenario file.

Adding a section (later subsystems: ``[hydro]``, ``[dem]``, ``[placement]``, ``[criteria]``)::

    from breachflow.scenario.config import register_section

    @register_section("hydro")
    class HydroSection:
        @classmethod
        def from_table(cls, table: dict, ctx: SectionContext) -> "HydroSection":
            ctx.check_keys(table, {"solver", "resolution"})
            return cls(resolution=ctx.quantity(table, "resolution", "length", required=True), ...)

Sections are found by name in :data:`sections` (entry-point group ``breachflow.scenario_sections``): the
sections of the closure simulation and of ensembles are built-in entry points (their parsers live in the
packages that use them), and third-party packages add theirs the same way.
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import BreachflowError, InputError, ParseError
from ..registry import Registry
from .geometry import BreachGeometry, LeveeGeometry
from .quantities import si_input
from .toml import line_of as _line_of

#: the scenario sections, by name
sections: Registry = Registry("scenario section", "breachflow.scenario_sections")

def register_section(name: str, cls=None):
    """Register a scenario section parser under *name*; a class decorator when *cls* is omitted."""

    def deco(c):
        sections.register(name, c)
        return c

    return deco if cls is None else deco(cls)


class SectionContext:
    """What a section parser needs: where it is (file, line lookup), and converters that name both."""

    def __init__(self, path: Path | None, text: str, section: str):
        self.path = path
        self.text = text
        self.section = section
        self.base_dir = path.parent if path is not None else Path.cwd()

    def line_of(self, key: str | None = None) -> int | None:
        return _line_of(self.text, self.section, key)

    def error(self, message: str, key: str | None = None) -> ParseError:
        where = f"[{self.section}]" + (f" {key}" if key else "")
        return ParseError(f"{where}: {message}", path=self.path, line=self.line_of(key))

    def renamed(self, table: dict, old: str, new: str | None = None, *, values: dict | None = None) -> dict:
        """Accept an old spelling with a DeprecationWarning naming the file, line, key and new spelling.
        The key *old* becomes *new* (a copy of *table* is returned; both given is an error); with *values*
        ``{old value: new value}`` instead, those values of the key *old* are renamed."""
        import warnings

        def warn(key, was, now):
            line = self.line_of(key)
            where = f"{self.path or '<scenario>'}" + (f", line {line}" if line else "")
            warnings.warn(f"{where}: [{self.section}] {was} is deprecated; write {now}", DeprecationWarning,
                          stacklevel=4)

        if values is not None:
            value = table.get(old)
            if isinstance(value, str) and value in values:
                warn(old, f"{old} = {value!r}", f"{old} = {values[value]!r}")
                table = {**table, old: values[value]}
            return table
        if old in table:
            if new in table:
                raise self.error(f"give {new!r} only ({old!r} is its deprecated spelling)", old)
            warn(old, old, new)
            table = {(new if k == old else k): v for k, v in table.items()}
        return table

    def check_keys(self, table: dict, allowed, *, subtables=()) -> None:
        """Raise for any key of *table* not in *allowed* (nor an allowed sub-table name)."""
        allowed = set(allowed) | set(subtables)
        for key, value in table.items():
            if key not in allowed:
                close = [a for a in sorted(allowed) if _similar(a, key)]
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise self.error(f"unknown key{hint} (allowed: {', '.join(sorted(allowed))})", key)
            if isinstance(value, dict) and key not in subtables:
                raise self.error("expected a value, found a table", key)

    def quantity(self, table: dict, key: str, kind: str, *, required: bool = False, default=None,
                 default_unit: str | None = None, positive: bool = False, nonnegative: bool = False,
                 dim: str | None = None):
        """SI value of ``table[key]``: a float, or for a list a DataArray along *dim* (default: *key*,
        use the API parameter name, e.g. ``polder_area``). Errors name the file and line."""
        if key not in table:
            if required:
                raise self.error(f"required key {key!r} is missing", None)
            if default is None:
                return None
            value = default
        else:
            value = table[key]
        try:
            return si_input(value, name=dim or key, kind=kind, default_unit=default_unit, positive=positive,
                            nonnegative=nonnegative)
        except BreachflowError as exc:
            raise self.error(str(exc).removeprefix(f"{dim or key}: "), key) from None

    def raw(self, table: dict, key: str, *, types=(str,), required: bool = False, default=None):
        if key not in table:
            if required:
                raise self.error(f"required key {key!r} is missing")
            return default
        value = table[key]
        if not isinstance(value, types):
            names = " or ".join(t.__name__ for t in types)
            raise self.error(f"expected {names}, got {type(value).__name__} {value!r}", key)
        return value

    def file(self, table: dict, key: str) -> Path | None:
        value = self.raw(table, key)
        if value is None:
            return None
        p = Path(value)
        p = p if p.is_absolute() else self.base_dir / p
        if not p.exists():
            raise self.error(f"file not found: {p}", key)
        return p


# --------------------------------------------------------------------------------------------- sections
@register_section("scenario")
@dataclass
class ScenarioInfo:
    """``[scenario]``: ``name``, ``description``."""

    name: str = ""
    description: str = ""

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"name", "description"})
        return cls(ctx.raw(table, "name", default=""), ctx.raw(table, "description", default=""))


@register_section("flood")
@dataclass
class FloodSection:
    """``[flood]``: ``preset`` | ``surge_height``, ``rise_rate``, ``fall_rate``; or ``hydrograph`` (CSV)
    with ``ground_elevation`` / ``hydrograph_column``; ``breach_time``, ``duration``."""

    preset: str | None = None
    surge_height: Any = None
    rise_rate: Any = None
    fall_rate: Any = None
    hydrograph: Path | None = None
    ground_elevation: Any = None
    hydrograph_column: str | None = None
    breach_time: Any = 0.0
    duration: Any = None

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"preset", "surge_height", "rise_rate", "fall_rate", "hydrograph", "ground_elevation",
                               "hydrograph_column", "breach_time", "duration"})
        out = cls(
            preset=ctx.raw(table, "preset"),
            surge_height=ctx.quantity(table, "surge_height", "length", positive=True),
            rise_rate=ctx.quantity(table, "rise_rate", "rate", nonnegative=True),
            fall_rate=ctx.quantity(table, "fall_rate", "rate", nonnegative=True),
            hydrograph=ctx.file(table, "hydrograph"),
            ground_elevation=ctx.quantity(table, "ground_elevation", "length"),
            hydrograph_column=ctx.raw(table, "hydrograph_column"),
            breach_time=ctx.quantity(table, "breach_time", "time", default="0 h"),
            duration=ctx.quantity(table, "duration", "time", positive=True, dim="flood_duration"),
        )
        if out.hydrograph is not None and any(v is not None for v in (out.preset, out.surge_height, out.rise_rate, out.fall_rate)):
            raise ctx.error("give either hydrograph or preset/surge_height/rise_rate/fall_rate", "hydrograph")
        if out.hydrograph is None and out.preset is None and (out.surge_height is None or out.fall_rate is None):
            raise ctx.error("needs preset, or surge_height and fall_rate, or hydrograph")
        if out.preset is not None:
            from .presets import flood_preset

            try:
                flood_preset(out.preset)
            except InputError as exc:
                raise ctx.error(str(exc), "preset") from None
        return out

    def window_kwargs(self) -> dict:
        if self.hydrograph is not None:
            from .hydrograph import MeasuredHydrograph

            hyd = MeasuredHydrograph.from_csv(self.hydrograph, ground_elevation=self.ground_elevation,
                                              column=self.hydrograph_column)
            kw = {"hydrograph": hyd}
        else:
            kw = {k: _si_back(getattr(self, k), unit) for k, unit in
                  (("surge_height", "m"), ("rise_rate", "m/s"), ("fall_rate", "m/s")) if getattr(self, k) is not None}
            if self.preset is not None:
                kw["preset"] = self.preset
        kw["breach_time"] = _si_back(self.breach_time, "s")
        if self.duration is not None:
            kw["flood_duration"] = _si_back(self.duration, "s")
        return kw


@register_section("breach")
@dataclass
class BreachSection:
    """``[breach]``: ``discharge`` | ``length`` (+ ``mean_velocity``); geometry ``depth``, ``wall_slope``
    (H per V; left out: 1V:0.5H, the report's mostly 2V:1H, or the preset site's own breach), ``scour_depth``; growth: ``growth`` (equation names/numbers or ``"all"``), ``max_length`` (a length or
    an equation 2.9–2.11), ``development_time`` (list of times)."""

    discharge: Any = None
    length: Any = None
    mean_velocity: Any = None
    depth: Any = None
    wall_slope: Any = None
    scour_depth: Any = None
    growth: Any = None
    max_length: Any = None
    development_time: Any = None

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"discharge", "length", "mean_velocity", "depth", "wall_slope", "scour_depth",
                               "growth", "max_length", "development_time"})
        out = cls(
            discharge=ctx.quantity(table, "discharge", "discharge", positive=True, dim="breach_discharge"),
            length=ctx.quantity(table, "length", "length", positive=True, dim="breach_length"),
            mean_velocity=ctx.quantity(table, "mean_velocity", "speed", positive=True),
            depth=ctx.quantity(table, "depth", "length", positive=True),
            wall_slope=ctx.quantity(table, "wall_slope", "dimensionless", default_unit="", nonnegative=True),
            scour_depth=ctx.quantity(table, "scour_depth", "length", nonnegative=True),
            growth=ctx.raw(table, "growth", types=(str, list)),
            max_length=ctx.raw(table, "max_length", types=(str,)),
            development_time=ctx.quantity(table, "development_time", "time", nonnegative=True),
        )
        if out.discharge is not None and out.mean_velocity is not None:
            raise ctx.error("give discharge, or length with mean_velocity, not both", "mean_velocity")
        if out.growth is not None:
            from .growth import _names, growth_equations

            try:
                _names(growth_equations, out.growth)
            except InputError as exc:
                raise ctx.error(str(exc), "growth") from None
        if out.max_length is not None:
            from .growth import _resolve, max_length_equations

            try:
                _resolve(max_length_equations, out.max_length)
            except InputError:
                try:
                    si_input(out.max_length, name="max_length", kind="length", positive=True)
                except BreachflowError as exc:
                    raise ctx.error(f"neither a maximum-length equation nor a length ({exc})", "max_length") from None
        return out

    def geometry(self) -> BreachGeometry | None:
        """The breach of ``length`` and ``depth``; a key left out takes the default of
        :class:`~breachflow.scenario.geometry.BreachGeometry`."""
        if self.length is None or self.depth is None:
            return None
        given = {k: float(v) for k, v in (("wall_slope", self.wall_slope), ("scour_depth", self.scour_depth))
                 if v is not None}
        return BreachGeometry(length=float(self.length), depth=float(self.depth), **given)


@register_section("levee")
@dataclass
class LeveeSection:
    """``[levee]``: ``height``, ``crown_width``, ``flood_slope``, ``protected_slope`` (1V:mH → m)."""

    geometry: LeveeGeometry

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"height", "crown_width", "flood_slope", "protected_slope"})
        return cls(LeveeGeometry(
            height=ctx.quantity(table, "height", "length", required=True, positive=True),
            crown_width=ctx.quantity(table, "crown_width", "length", default="0 m", nonnegative=True),
            flood_slope=ctx.quantity(table, "flood_slope", "dimensionless", default=0.0, default_unit="", nonnegative=True),
            protected_slope=ctx.quantity(table, "protected_slope", "dimensionless", default=0.0, default_unit="",
                                         nonnegative=True)))


@register_section("wind")
@dataclass
class WindSection:
    """``[wind]``: ``record`` (CSV ``time [h], speed [m/s]`` relative to the crest), ``limit``
    (``"land"``, ``"ship"`` or a speed), ``crest_time`` (ISO date-time, for date-time records)."""

    record: Path
    limit: Any = "land"
    crest_time: str | None = None

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"record", "limit", "crest_time"})
        record = ctx.file(table, "record")
        if record is None:
            raise ctx.error("required key 'record' is missing")
        limit = ctx.raw(table, "limit", default="land")
        from .wind import crane_limit

        try:
            crane_limit(limit)
        except BreachflowError as exc:
            raise ctx.error(str(exc), "limit") from None
        return cls(record, limit, ctx.raw(table, "crest_time"))

    def window_kwargs(self) -> dict:
        from .wind import WindRecord

        return {"wind": WindRecord.from_csv(self.record, crest_time=self.crest_time), "wind_limit": self.limit}


# --------------------------------------------------------------------------------------------- scenario
@dataclass
class Scenario:
    """A parsed scenario: its sections by name (``scenario["flood"]`` or ``scenario.flood``)."""

    path: Path | None
    sections: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        info = self.sections.get("scenario")
        return (info.name if info and info.name else (self.path.stem if self.path else "scenario"))

    @property
    def description(self) -> str:
        info = self.sections.get("scenario")
        return info.description if info else ""

    def __getitem__(self, name: str):
        return self.sections[name]

    def __contains__(self, name: str) -> bool:
        return name in self.sections

    def __getattr__(self, name: str):
        try:
            return self.__dict__["sections"][name]
        except KeyError:
            raise AttributeError(name) from None

    def get(self, name: str, default=None):
        return self.sections.get(name, default)

    def window_kwargs(self) -> dict:
        """Keyword arguments of :func:`breachflow.scenario.closure_window` from [flood], [polder], [breach], [wind]."""
        for need in ("flood", "polder", "breach"):
            if need not in self.sections:
                raise ParseError(f"closure window needs a [{need}] section", path=self.path)
        flood, polder, breach = self["flood"], self["polder"], self["breach"]
        if polder.inundation_depth is None:
            raise ParseError("[polder]: the closure window needs inundation_depth (the permissible mean depth d_I)",
                             path=self.path, line=_line_of(_read(self.path), "polder", None))
        kw = flood.window_kwargs()
        kw.update(polder_area=_si_back(polder.area, "m^2"), inundation_depth=_si_back(polder.inundation_depth, "m"),
                  pump_capacity=_si_back(polder.pump_capacity, "m^3/s"))
        if breach.discharge is not None:
            kw["breach_discharge"] = _si_back(breach.discharge, "m^3/s")
        elif breach.length is not None:
            kw["breach_length"] = _si_back(breach.length, "m")
            if breach.mean_velocity is not None:
                kw["mean_velocity"] = _si_back(breach.mean_velocity, "m/s")
        else:
            raise ParseError("[breach]: needs discharge, or length (with mean_velocity, default 3 m/s)",
                             path=self.path, line=_line_of(_read(self.path), "breach", None))
        if "wind" in self.sections:
            kw.update(self["wind"].window_kwargs())
        return kw


def load_scenario(path) -> Scenario:
    """Parse a scenario TOML file; every problem is a :class:`~breachflow.errors.ParseError` naming the file and line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot read scenario ({exc.strerror})") from None
    return parse_scenario(text, path=path)


def parse_scenario(text: str, path: Path | None = None) -> Scenario:
    """Parse scenario TOML *text* (``path`` only names the file in errors and anchors relative paths)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise ParseError(f"invalid TOML: {exc}", path=path, line=int(m.group(1)) if m else None) from None
    scenario = Scenario(path=path)
    for name, table in data.items():
        if not isinstance(table, dict):
            raise ParseError(f"top-level key {name!r} outside any [section]", path=path, line=_line_of(text, "", name))
        cls = _section_class(name, text, path)
        scenario.sections[name] = cls.from_table(table, SectionContext(path, text, name))
    from .plausibility import check_scenario

    check_scenario(data, text, path)  # the one place plausible ranges are checked (docs/run-safety.md)
    return scenario


def _section_class(name: str, text: str, path):
    if name not in sections:
        raise ParseError(f"unknown section [{name}]; known: {', '.join('[' + s + ']' for s in sections.available())}",
                         path=path, line=_line_of(text, name, None))
    return sections.get(name)






def _similar(a: str, b: str) -> bool:
    a, b = a.lower(), b.lower()
    if a in b or b in a:
        return True
    return sum(x != y for x, y in zip(a, b)) + abs(len(a) - len(b)) <= 2


def _si_back(value, unit: str):
    """Hand an SI value back to the API: floats become strings with their SI unit; DataArrays keep attrs."""
    import xarray as xr

    if value is None or isinstance(value, xr.DataArray):
        return value
    return f"{float(value)!r} {unit}"


def _read(path) -> str:
    try:
        return Path(path).read_text() if path else ""
    except OSError:
        return ""


# the [polder] section lives with the polder's water balance; imported here so that it is registered
# with the built-in sections and stays importable from this module
