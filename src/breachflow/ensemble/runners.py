"""Member runners: what one ensemble member computes (registry ``breachflow.member_runners``).

A member runner is a class with one method::

    @member_runners.register("closure")
    class ClosureRunner:
        sections = None                       # scenario sections it reads (None: all of them)
        outputs = {**ClosureWindowRunner.outputs, **CLOSURE_OUTPUTS}   # CF attributes of its results
        optional_outputs = ClosureWindowRunner.optional_outputs         # declared, but only present sometimes
        def __init__(self, **options): ...    # the spec's [ensemble.options] table
        def run(self, member: MemberScenario, run_dir: Path, seed: int) -> dict: ...

``run`` gets the member's scenario (:class:`MemberScenario`: ``member.scenario()`` parses it with
the scenario loader, errors naming the member's ``scenario.toml``; ``member.table`` the raw tables;
``member.values`` the varied values), its own run directory (write member outputs there; it is kept
between attempts, so a runner may resume from what it finds) and its deterministic seed (use it for
every random draw). It returns a flat dict of scalar results, each value one of

* a :class:`pint.Quantity` (converted to SI; the declared unit in ``outputs`` wins),
* ``(value, "unit")``,
* a float / int (in the unit declared in ``outputs``, else dimensionless),
* a bool (stored as a CF flag) or a str (categorical).

It raises (any exception) when the member cannot be computed; the executor records the error type and
message and carries on with the other members. ``outputs`` declares the results' CF attributes
(``units``, ``long_name``, ``standard_name``, ``flag_values``/``flag_meanings``, ``display_units``,
``dtype`` in ``f8 i1 i8 bool str``) so that the Dataset has every variable even when members fail;
undeclared results are added as they come. Runners are instantiated on the worker, once per member, and
are shipped to workers by reference: the class must live in an importable module.

A runner is found by name in the registry (``member_runners.get(name)``); the built-in ``closure`` runner
(``breachflow.ensemble.closure``, which builds on this module) is declared as an entry point of the group
``breachflow.member_runners``, as third-party runners are.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np
import pint

from ..errors import InputError
from ..registry import Registry
from ..units import Q_
from .spec import SI_UNIT_TEXT, dump_toml

member_runners: Registry = Registry("member runner", "breachflow.member_runners")

#: Results the "closure" runner (closure-cycle issue) returns besides the window's (:func:`window_scalars`);
#: their names and units are fixed in ``data_schemas/ensemble_result.json``.
CLOSURE_OUTPUTS: dict[str, dict] = {
    "cycles": {"units": "1", "dtype": "i8", "long_name": "closure cycles run"},
    "masses_placed": {"units": "1", "dtype": "i8", "long_name": "masses placed"},
    "tonnage": {"units": "kg", "dtype": "f8", "long_name": "total mass placed", "display_units": "t"},
    "closure_duration": {"units": "s", "dtype": "f8", "display_units": "h",
                         "long_name": "simulated duration of the closure operation at the placement rate, "
                                      "the seal stage included"},
    "closure_achieved": {"dtype": "bool", "long_name": "the end criteria of the closure were met"},
    "governing_criterion": {"dtype": "str", "long_name": "end criterion that ended the closure run"},
    "peak_velocity": {"units": "m/s", "dtype": "f8", "long_name": "maximum depth-averaged speed before any placement"},
    "initial_breach_discharge": {"units": "m^3/s", "dtype": "f8",
                                 "long_name": "discharge through the open breach (positive into the polder)"},
    "final_breach_discharge": {"units": "m^3/s", "dtype": "f8",
                               "long_name": "discharge through the breach after the last cycle "
                                            "(positive into the polder)"},
    "final_seepage_discharge": {"units": "m^3/s", "dtype": "f8",
                                "long_name": "part of final_breach_discharge seeping through a porous pile"},
    "feasible": {"dtype": "bool", "long_name": "closure achieved before the closure window ends"},
}


@runtime_checkable
class MemberRunner(Protocol):
    """Protocol of a member runner (see the module docstring)."""

    sections: ClassVar[frozenset[str] | None]
    outputs: ClassVar[dict[str, dict]]

    def run(self, member: "MemberScenario", run_dir: Path, seed: int) -> dict[str, Any]: ...


@dataclass
class MemberScenario:
    """The scenario of one member as handed to a runner.

    ``table``: the complete scenario tables (base + varied values, raw TOML values, units in strings);
    ``values`` / ``values_si``: the varied parameters by dimension name (as given / SI);
    ``paths``: dimension name -> dotted scenario path; ``path``: the member's ``scenario.toml``.
    """

    key: str
    number: int
    table: dict
    values: dict[str, Any]
    values_si: dict[str, Any]
    paths: dict[str, str]
    path: Path | None = None
    #: replicate number when the spec has ``replicates > 1`` (the seed then differs per replicate and a
    #: runner must use it even where the scenario fixes a seed), else None
    replicate: int | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    def text(self, sections=None) -> str:
        """TOML text of the member scenario (only *sections*, in the file's order, when given)."""
        names = self._ordered(sections)
        return dump_toml(self.table, names)

    def _ordered(self, sections=None) -> list[str]:
        if sections is None:
            return list(self.table)
        wanted = [s for s in self.table if s in set(sections)]
        return wanted + [s for s in self.table if s not in set(sections)]

    def write(self, path: Path, sections=None) -> Path:
        """Write the scenario TOML (runner sections first, so parse errors name the right line)."""
        from ..atomic import atomic_write_text

        order = self._ordered(sections)
        atomic_write_text(dump_toml(self.table, order), path)
        self.path = Path(path)
        return self.path

    def scenario(self, sections=None):
        """The parsed :class:`breachflow.scenario.Scenario` (only the given *sections*; errors name the
        member's ``scenario.toml`` and line)."""
        key = None if sections is None else tuple(sorted(sections))
        if key not in self._cache:
            from ..scenario import parse_scenario

            names = self._ordered(sections)
            used = names if sections is None else [n for n in names if n in set(sections)]
            self._cache[key] = parse_scenario(dump_toml(self.table, used), path=self.path)
        return self._cache[key]


# ------------------------------------------------------------------------------------------ results
@dataclass
class ResultValue:
    """One normalised scalar result: value (SI float, int, bool or str), its unit text and attributes."""

    value: Any
    kind: str                      # "float", "int", "bool", "str"
    units: str = ""
    attrs: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        v = self.value
        if self.kind == "float" and not math.isfinite(v):
            v = repr(v)  # "nan" / "inf" survive JSON as strings
        return {"value": v, "kind": self.kind, "units": self.units}


def _unit_text(q: pint.Quantity, declared: str | None) -> tuple[float, str]:
    if declared is not None and declared != "":
        target = "" if declared == "1" else declared.replace("^", "**")
        try:
            return float(q.to(target).magnitude), declared
        except pint.DimensionalityError:
            raise InputError(f"result has unit {q.units:~}, declared {declared!r}") from None
    for unit in SI_UNIT_TEXT:
        ref = Q_(1.0, "" if unit == "1" else unit.replace("^", "**"))
        if ref.dimensionality == q.dimensionality:
            return float(q.to(ref.units).magnitude), unit
    base = q.to_base_units()
    return float(base.magnitude), f"{base.units:~}".replace(" ", "").replace("**", "^")


def normalise_results(raw: dict, outputs: dict[str, dict]) -> dict[str, ResultValue]:
    """Turn a runner's returned dict into :class:`ResultValue` s (SI, declared units)."""
    if not isinstance(raw, dict):
        raise InputError(f"member runner returned {type(raw).__name__}, expected a dict of scalar results")
    out = {}
    for name, v in raw.items():
        decl = outputs.get(name, {})
        dunits = decl.get("units")
        if isinstance(v, tuple) and len(v) == 2 and isinstance(v[1], str):
            v = Q_(float(v[0]), "" if v[1] in ("1", "") else v[1].replace("^", "**"))
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, np.ndarray) and v.ndim == 0:
            v = v.item()
        if isinstance(v, pint.Quantity):
            if np.ndim(v.magnitude) != 0:
                raise InputError(f"result {name!r}: expected a scalar, got shape {np.shape(v.magnitude)}")
            mag, units = _unit_text(v, dunits)
            out[name] = ResultValue(mag, "float", units)
        elif isinstance(v, bool):
            out[name] = ResultValue(bool(v), "bool", "")
        elif isinstance(v, int):
            out[name] = ResultValue(int(v), "int", dunits or "1")
        elif isinstance(v, float):
            out[name] = ResultValue(float(v), "float", dunits or "1")
        elif isinstance(v, str):
            out[name] = ResultValue(v, "str", "")
        else:
            raise InputError(f"result {name!r}: expected a scalar (Quantity, number, bool, str), got {type(v).__name__}")
        dtype = decl.get("dtype")
        if dtype is not None and out[name].kind == "float" and dtype.startswith("i"):
            raise InputError(f"result {name!r}: declared integer, got a float")
    return out


# ------------------------------------------------------------------------------------------ window runner
_WINDOW_FLOAT = {
    "closure_window": ("breach closure window t_B = min(t_Q, t_I), elapsed from the breach", "s"),
    "balance_time": ("breach balance time t_Q, elapsed from the breach", "s"),
    "inundation_time": ("polder inundation time t_I, elapsed from the breach", "s"),
    "depth_at_window_end": ("average polder water depth at the end of the closure window", "m"),
    "polder_rise_rate": ("polder stage rise rate (Q_D - Q_P) / A_P (r_P)", "m/s"),
    "breach_discharge": ("breach discharge into the polder (Q_D)", "m^3/s"),
    "work_start_delay": ("delay from the breach until the wind allows crane work", "s"),
    "working_time": ("time for closure work inside the window after the wind delay", "s"),
}
_WINDOW_FLAGS = ("balance_reached", "inundation_reached", "wind_calm_reached")


@member_runners.register("window")  # the former name, kept as an alias (an ensemble spec warns)
@member_runners.register("closure_window")
class ClosureWindowRunner:
    """Closure window of the member's scenario (docs/theory.md, *Closure window*): ``breachflow.scenario.closure_window`` on the
    member's ``[flood]``, ``[polder]``, ``[breach]`` (and ``[wind]``), reduced to scalars: t_B, t_Q, t_I,
    depth at the window's end, r_P, Q_D, the governing constraint (flag) and the reached-flags.
    A member scenario must be scalar (vary parameters in the ensemble, not with lists in the scenario)."""

    sections: ClassVar[frozenset[str]] = frozenset({"scenario", "flood", "polder", "breach", "levee", "wind"})
    outputs: ClassVar[dict[str, dict]] = {
        **{k: {"units": u, "long_name": ln, "dtype": "f8", "display_units": {"s": "h", "m/s": "cm/h", "m": "cm"}.get(u, u)}
           for k, (ln, u) in _WINDOW_FLOAT.items()},
        "governing": {"units": "1", "dtype": "i1", "long_name": "constraint governing the closure window",
                      "flag_values": [0, 1, 2],
                      "flag_meanings": "breach_balance polder_inundation no_limit_within_flood"},
        **{k: {"dtype": "bool", "long_name": k.replace("_", " ")} for k in _WINDOW_FLAGS},
    }
    optional_outputs: ClassVar[frozenset[str]] = frozenset({"work_start_delay", "working_time", "wind_calm_reached"})

    def __init__(self, **options):
        if options:
            raise InputError(f"member runner 'closure_window' takes no options, got {sorted(options)}")

    def run(self, member: MemberScenario, run_dir: Path, seed: int) -> dict[str, Any]:
        from ..scenario import closure_window

        scenario = member.scenario(self.sections)
        ds = closure_window(**scenario.window_kwargs())
        return window_scalars(ds)


def window_scalars(ds) -> dict[str, Any]:
    """Reduce a scalar closure-window Dataset to the window runner's results (reused by other runners)."""
    out: dict[str, Any] = {}
    for name, (_, unit) in _WINDOW_FLOAT.items():
        if name in ds:
            out[name] = Q_(_scalar(ds, name), "" if unit == "1" else unit.replace("^", "**"))
    out["governing"] = int(_scalar(ds, "governing"))
    for name in _WINDOW_FLAGS:
        if name in ds:
            out[name] = bool(_scalar(ds, name))
    return out


def _scalar(ds, name):
    da = ds[name]
    extra = [d for d in da.dims if d not in ("wind_time", "hydrograph_time")]
    if extra:
        raise InputError(f"member scenario gives {name} along {extra}: a member must be a single scenario "
                         "(vary parameters with [ensemble.vary], not with lists in the scenario)")
    return da.values.item()


# ------------------------------------------------------------------------------------------ synthetic runner
@member_runners.register("synthetic")
class SyntheticRunner:
    """A fixed CPU workload for benchmarking and testing the ensemble machinery (not physics).

    Explicit 2-D diffusion ``u <- u + k lap(u)`` (k = 0.2) of a random field drawn from the member's seed,
    on an ``n x n`` grid for ``steps`` steps; ``[synthetic]`` in the member scenario may set ``steps``,
    ``size``, ``amplitude`` (varied like any parameter) and ``fail = true`` (raise: failure injection).
    Options (``[ensemble.options]``): defaults of ``steps`` (200) and ``size`` (64).
    Results: ``field_mean``, ``field_max`` (1), ``field_rms_amplitude`` (m, amplitude x rms), ``steps``,
    ``smooth`` (max-min below 1 % of the initial range), ``label``.
    """

    sections: ClassVar[frozenset[str]] = frozenset({"synthetic"})
    outputs: ClassVar[dict[str, dict]] = {
        "field_mean": {"units": "1", "dtype": "f8", "long_name": "mean of the diffused field"},
        "field_max": {"units": "1", "dtype": "f8", "long_name": "maximum of the diffused field"},
        "field_rms_amplitude": {"units": "m", "dtype": "f8", "long_name": "amplitude times rms of the field"},
        "steps": {"units": "1", "dtype": "i8", "long_name": "diffusion steps done"},
        "smooth": {"dtype": "bool", "long_name": "field range below 1 % of the initial range"},
        "label": {"dtype": "str", "long_name": "member label"},
    }

    def __init__(self, steps: int = 200, size: int = 64):
        self.steps, self.size = int(steps), int(size)

    def run(self, member: MemberScenario, run_dir: Path, seed: int) -> dict[str, Any]:
        table = member.table.get("synthetic", {})
        unknown = set(table) - {"steps", "size", "amplitude", "fail"}
        if unknown:
            raise InputError(f"[synthetic]: unknown key(s) {sorted(unknown)}")
        if table.get("fail", False):
            raise RuntimeError(f"injected failure in member {member.key}")
        steps = int(table.get("steps", self.steps))
        n = int(table.get("size", self.size))
        amplitude = Q_(table.get("amplitude", "1 m")).to("m").magnitude
        u = diffuse(np.random.default_rng(seed).random((n, n)), steps)
        return {"field_mean": float(u.mean()), "field_max": float(u.max()),
                "field_rms_amplitude": Q_(amplitude * float(np.sqrt((u ** 2).mean())), "m"),
                "steps": steps, "smooth": bool(np.ptp(u) < 0.01), "label": f"n{n}-s{steps}"}


def diffuse(u: np.ndarray, steps: int, k: float = 0.2) -> np.ndarray:
    """``steps`` explicit diffusion steps with fixed (copied) boundary values; numpy, single thread."""
    u = np.array(u, dtype=float)
    lap = np.empty_like(u[1:-1, 1:-1])
    for _ in range(steps):
        np.add(u[:-2, 1:-1], u[2:, 1:-1], out=lap)
        lap += u[1:-1, :-2]
        lap += u[1:-1, 2:]
        lap -= 4.0 * u[1:-1, 1:-1]
        u[1:-1, 1:-1] += k * lap
    return u
