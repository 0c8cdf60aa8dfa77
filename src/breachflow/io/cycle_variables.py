"""Per-cycle figures of a closure run as CF variables along the ``cycle`` dimension.

Each closure cycle ``<g>`` ends with a handful of scalar figures — the discharge through the breach,
the flow speed in the gap, the seepage through the pile, the masses and tonnage placed and lost, the
value of every end criterion and whether it is met. They are written as variables of dimension
``cycle`` (length 1 in a cycle file), so that ::

    xr.open_mfdataset("RUN/cycle_*.nc")["breach_discharge"]

is the breach discharge per cycle, and ``breachflow combine`` and the ensemble dataset carry the same
variables stacked along ``cycle``.

The table :data:`CYCLE_VARIABLES` is the one place these variables are defined: a
:class:`CycleVariable` names the variable, the attribute of the cycle's report
(:class:`breachflow.cycle.driver.CycleReport`) it takes its value from (or a function of the report),
its CF attributes and its type. A new per-cycle figure is one more entry (:func:`register_cycle_variable`).
The criteria, whose set depends on the scenario, add three variables each
(:func:`criteria_variables`): ``criterion_<name>`` (the value, in the criterion's units),
``criterion_<name>_threshold`` and ``criterion_<name>_met`` (flag).

Text figures (the criterion that ended the run, the verdict, what the flow solve did) are written as
CF character arrays (a ``*_strlen`` dimension), not NetCDF-4 variable-length strings, which CF-1.8
checkers and GDAL do not read.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import xarray as xr

#: flag attributes of a yes/no variable
FLAG_ATTRS = {"flag_values": np.array([0, 1], "i1"), "flag_meanings": "no yes"}


@dataclass(frozen=True)
class CycleVariable:
    """One per-cycle figure: variable *name*, where its value comes from (*source*: an attribute name
    of the cycle report, or a function of the report), its CF *attrs* (``units``, ``long_name``,
    ``standard_name`` where CF has one) and its *kind* (``float``, ``int``, ``flag``, ``str``);
    *scale* converts the report's value to the variable's units (e.g. 1000 for t -> kg)."""

    name: str
    source: str | Callable[[Any], Any]
    attrs: dict = field(default_factory=dict)
    kind: str = "float"
    scale: float = 1.0

    def value(self, report) -> Any:
        v = self.source(report) if callable(self.source) else getattr(report, self.source)
        if self.kind == "float":
            return float(v) * self.scale
        if self.kind == "int":
            return int(v)
        if self.kind == "flag":
            return int(bool(v))
        return str(v)

    def variable(self, report) -> xr.Variable:
        v = self.value(report)
        dtype = {"float": "f8", "int": "i4", "flag": "i1"}.get(self.kind)
        data = np.array([v], dtype=dtype) if dtype else np.array([v], dtype=str)
        attrs = dict(self.attrs)
        if self.kind == "flag":
            attrs = {**attrs, **FLAG_ATTRS}
        return xr.Variable(("cycle",), data, attrs)


def _speed(long_name: str, **extra) -> dict:
    return {"units": "m s-1", "standard_name": "flood_water_speed", "long_name": long_name, **extra}


#: The per-cycle variables of every cycle file, in file order (see the module docstring).
CYCLE_VARIABLES: list[CycleVariable] = [
    CycleVariable("masses_placed", "masses", {"units": "1", "long_name": "masses released so far (all cycles)"}, "int"),
    CycleVariable("masses_lost", "left_domain", {"units": "1", "long_name": "masses carried out of the domain so far"}, "int"),
    CycleVariable("masses_lost_cycle", "lost_cycle",
                  {"units": "1", "long_name": "masses carried out of the breach area in this cycle"}, "int"),
    CycleVariable("masses_not_at_rest", "not_at_rest",
                  {"units": "1", "long_name": "masses in the domain still moving at the end of the cycle"}, "int"),
    CycleVariable("mass_in_place", "tonnage", {"units": "kg", "long_name": "mass of the placed masses inside the domain"},
                  scale=1000.0),
    CycleVariable("mass_placed_cycle", "placed_cycle_tonnage",
                  {"units": "kg", "long_name": "mass of the masses released in this cycle"}, scale=1000.0),
    CycleVariable("mass_lost", "lost_tonnage", {"units": "kg", "long_name": "mass carried out of the domain so far"},
                  scale=1000.0),
    CycleVariable("mass_lost_cycle", "lost_cycle_tonnage",
                  {"units": "kg", "long_name": "mass carried out of the breach area in this cycle"}, scale=1000.0),
    CycleVariable("breach_discharge", "breach_discharge",
                  {"units": "m3 s-1", "long_name": "discharge through the breach section at the levee line "
                   "(positive from the flood side into the polder)"}),
    CycleVariable("seepage_discharge", "seepage_discharge",
                  {"units": "m3 s-1", "long_name": "part of breach_discharge seeping through the porous pile"}),
    CycleVariable("discharge_proxy", "discharge_proxy",
                  {"units": "m3 s-1", "long_name": "discharge proxy: unit discharge through the breach times its length"}),
    CycleVariable("max_speed", "max_speed", _speed("largest depth-averaged flow speed in the domain",
                                                   cell_methods="area: maximum")),
    CycleVariable("gap_speed", "gap_speed", _speed("largest depth-averaged flow speed in the breach area",
                                                   cell_methods="area: maximum")),
    CycleVariable("gap_max_speed", "gap_max_speed", _speed("largest depth-averaged flow speed in the gap section",
                                                           cell_methods="area: maximum")),
    CycleVariable("gap_mean_speed", "gap_mean_speed",
                  _speed("depth-weighted mean flow speed in the gap section", cell_methods="area: mean")),
    CycleVariable("closure_achieved", "closed", {"long_name": "the end criteria of the closure are met"}, "flag"),
    CycleVariable("losses_flagged", "losses_flagged",
                  {"long_name": "more than the loss limit of all placed mass carried away so far"}, "flag"),
    CycleVariable("dem_converged", "dem_converged", {"long_name": "the masses came to rest within the DEM time limit"}, "flag"),
    CycleVariable("dem_steps", "dem_steps", {"units": "1", "long_name": "DEM time steps of the cycle"}, "int"),
    CycleVariable("governing_criterion", "governing", {"long_name": "end criterion that governs the closure"}, "str"),
    CycleVariable("verdict", "verdict", {"long_name": "why the run ends without closure (empty while it goes on)"}, "str"),
    CycleVariable("hydro_work", "hydro", {"long_name": "what the flow solve of the cycle did"}, "str"),
    CycleVariable("stability_check", "stability", {"long_name": "criterion 5 stability re-run of the cycle"}, "str"),
]


def register_cycle_variable(var: CycleVariable) -> CycleVariable:
    """Add *var* to :data:`CYCLE_VARIABLES` (replacing an entry of the same name); returns it."""
    for i, old in enumerate(CYCLE_VARIABLES):
        if old.name == var.name:
            CYCLE_VARIABLES[i] = var
            return var
    CYCLE_VARIABLES.append(var)
    return var


def criteria_variables(results) -> dict[str, xr.Variable]:
    """``criterion_<name>``, ``criterion_<name>_threshold`` and ``criterion_<name>_met`` for each
    :class:`~breachflow.cycle.criteria.CriterionResult` of a cycle."""
    out = {}
    for r in results:
        units = r.units or "1"
        what = r.description or r.name.replace("_", " ")
        out[f"criterion_{r.name}"] = xr.Variable(("cycle",), np.array([float(r.value)]),
                                                 {"units": units, "long_name": f"end criterion {r.name}: {what}"})
        out[f"criterion_{r.name}_threshold"] = xr.Variable(("cycle",), np.array([float(r.threshold)]),
                                                           {"units": units, "long_name": f"threshold of end criterion {r.name}"})
        out[f"criterion_{r.name}_met"] = xr.Variable(("cycle",), np.array([int(bool(r.satisfied))], "i1"),
                                                     {"long_name": f"end criterion {r.name} met", **FLAG_ATTRS})
    return out


def cycle_variables(report) -> dict[str, xr.Variable]:
    """Every per-cycle variable of cycle *report* (length-1 ``cycle`` dimension): :data:`CYCLE_VARIABLES`
    then the criteria's."""
    out = {v.name: v.variable(report) for v in CYCLE_VARIABLES}
    out.update(criteria_variables(getattr(report, "criteria", ())))
    return out


#: The ``cycle`` coordinate variable: the cycle number <g> (int32, units "count"). CF has no axis for a
#: counter, and a CF time axis needs a reference date the closure operation does not have (its clock
#: starts with the first mass). GDAL's netCDF driver reads an extra dimension of a raster silently only
#: when its coordinate variable is a time or a vertical axis ("dimension #0 (cycle) is not a Time or
#: Vertical dimension" otherwise), so the cycle is declared the band axis ``axis = "Z"``: GIS tools list
#: the cycles as the levels of a grid, and the CF checker accepts a dimensionless Z coordinate. The
#: time of each cycle on the operation clock is a separate variable along ``cycle``. See docs/outputs.md.
CYCLE_COORD_ATTRS = {"long_name": "closure cycle <g>", "units": "count", "axis": "Z"}


def cycle_coordinate(cycles) -> xr.Variable:
    """The ``cycle`` coordinate variable for *cycles* (int32, :data:`CYCLE_COORD_ATTRS`)."""
    return xr.Variable(("cycle",), np.asarray(cycles, "i4"), dict(CYCLE_COORD_ATTRS))
