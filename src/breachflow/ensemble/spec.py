"""Ensemble specifications: a base scenario, the varied parameters with their values, the member runner.

An ensemble spec is a TOML file with an ``[ensemble]`` table; every other table of the file is part of the
base scenario (inline), optionally on top of a scenario file named by ``base``::

    [ensemble]
    name = "closure feasibility"
    runner = "closure_window"       # a name in the registry ``breachflow.member_runners``
    base = "site.toml"              # optional; this file's scenario tables override the file's
    seed = 2026                     # optional base seed of the per-member seeds (default 0)
    replicates = 10                 # optional: N placement seeds per parameter combination (dimension
                                    # "replicate"; the same N seeds for every combination: common
                                    # random numbers)
    output = "runs/feasibility"     # optional output directory, relative to this file
    workers = 2                     # optional defaults for the executor
    scheduler = "tcp://10.0.0.5:8786"

    [ensemble.vary]                 # full factorial over these (default design)
    "breach.length" = ["20 m", "30 m", "40 m"]
    "polder.area" = ["400 ha", "800 ha"]
    mass_size = { parameter = "placement.mass_size", values = ["1 m", "2 m"], long_name = "mass diameter" }

    [ensemble.options]              # keyword arguments of the runner's constructor
    [[ensemble.members]]            # explicit members instead of [ensemble.vary] (design "members")
    "breach.length" = "25 m"

    [flood]                         # the base scenario, as in any scenario file
    surge_height = "2.8 m"

A varied parameter is a dotted path ``section.key`` into the scenario; its dimension in the result is the
path with ``_`` for ``.`` (``breach_length``) unless the long form names it. Values are quantities with
units (``"800 ha"``: one dimension per parameter, converted to SI for the coordinate), bare numbers
(dimensionless), booleans, or words (categorical, e.g. flood preset names).
"""
from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError, ParseError, UnitError
from ..scenario.toml import dump_toml  # noqa: F401  (re-exported: the spec's own writer)
from ..units import Q_

#: Canonical SI unit text (UDUNITS-parsable) per dimensionality, for coordinates and results.
SI_UNIT_TEXT = ("m", "m^2", "m^3", "s", "m/s", "m^3/s", "m^2/s", "kg", "kg/m^3", "N", "Pa", "m/s^2", "1/s",
                "kg/s", "N*m", "J", "W", "K", "rad", "1")

_NUMBER_START = re.compile(r"^\s*[-+]?(\d|\.\d)")
_DIM_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
ENSEMBLE_KEYS = {"name", "description", "runner", "base", "design", "seed", "output", "workers", "scheduler",
                 "vary", "members", "options", "replicates"}
#: deprecated member-runner names and the current ones
RENAMED_RUNNERS = {"window": "closure_window"}


def looks_like_quantity(value) -> bool:
    """A string is read as a quantity when it starts with a number (``"800 ha"``, ``"-1.5 h"``)."""
    return isinstance(value, str) and bool(_NUMBER_START.match(value))


def si_value(value, *, name: str) -> tuple[Any, str]:
    """(SI magnitude, unit text) of a parameter value; words and booleans stay as they are (unit '')."""
    if isinstance(value, bool):
        return value, ""
    if isinstance(value, (int, float)):
        if isinstance(value, float) and not math.isfinite(value):
            raise InputError(f"{name}: value {value!r} is not finite")
        return float(value), "1"
    if isinstance(value, str):
        if not looks_like_quantity(value):
            return value, ""
        try:
            q = Q_(value)
        except Exception as exc:
            raise UnitError(f"{name}: cannot read {value!r} as a quantity ({exc})") from None
        if not hasattr(q, "dimensionality"):
            return float(q), "1"
        for unit in SI_UNIT_TEXT:
            ref = Q_(1.0, "" if unit == "1" else unit.replace("^", "**"))
            if ref.dimensionality == q.dimensionality:
                mag = float(q.to(ref.units).magnitude)
                if not math.isfinite(mag):
                    raise InputError(f"{name}: value {value!r} is not finite")
                return mag, unit
        base = q.to_base_units()
        return float(base.magnitude), f"{base.units:~}".replace(" ", "").replace("**", "^")
    raise InputError(f"{name}: expected a quantity string with units, a number, a boolean or a word; got {value!r}")


@dataclass(frozen=True)
class Parameter:
    """One varied scenario parameter: result dimension *name*, scenario *path*, its values as given."""

    name: str
    path: tuple[str, ...]
    values: tuple
    long_name: str = ""

    @property
    def dotted(self) -> str:
        return ".".join(self.path)

    @property
    def si(self) -> tuple[list, str]:
        """(SI values, unit text); unit '' for words/booleans."""
        pairs = [si_value(v, name=f"{self.dotted}[{i}]") for i, v in enumerate(self.values)]
        units = {u for _, u in pairs}
        if len(units) > 1:
            raise UnitError(f"{self.dotted}: values have different dimensions ({', '.join(sorted(u or 'word' for u in units))})")
        return [p[0] for p in pairs], pairs[0][1] if pairs else ""


@dataclass
class Member:
    """One member: its position (``index`` in the result grid, or the member number), parameter values."""

    number: int
    index: tuple[int, ...]
    values: dict[str, Any]        # dimension name -> value as given ("20 m")
    values_si: dict[str, Any]     # dimension name -> SI magnitude / word
    key: str = ""                 # run-directory name: hash of runner, options, base scenario, values
    seed: int = 0                 # hash of the member's parameter values (and the spec seed)
    replicate: int | None = None  # replicate number (spec.replicates > 1), else None


@dataclass
class EnsembleSpec:
    """A parsed ensemble spec. Build with :func:`load_spec`, :func:`parse_spec` or :meth:`from_dict`."""

    base: dict                     # base scenario tables (raw TOML values, relative file paths resolved)
    parameters: list[Parameter]
    runner: str = "closure_window"
    design: str = "factorial"      # "factorial" or "members"
    member_values: list[dict[str, Any]] = field(default_factory=list)   # design "members"
    options: dict = field(default_factory=dict)
    name: str = "ensemble"
    description: str = ""
    seed: int = 0
    output: Path | None = None
    workers: int | None = None
    scheduler: str | None = None
    path: Path | None = None
    text: str = ""
    #: placement seeds per parameter combination (> 1 adds the ``replicate`` dimension)
    replicates: int = 1

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, data: dict, *, path: Path | None = None, text: str = "") -> "EnsembleSpec":
        """Spec from a dict shaped like the TOML file (``{"ensemble": {...}, "flood": {...}, ...}``)."""
        data = copy.deepcopy(data)
        where = path or "<ensemble spec>"
        table = data.pop("ensemble", None)
        if not isinstance(table, dict):
            raise ParseError("missing [ensemble] table", path=path)

        def err(msg, key=None):
            return ParseError(f"[ensemble]{' ' + key if key else ''}: {msg}", path=path, line=_line_of(text, key))

        for key in table:
            if key not in ENSEMBLE_KEYS:
                raise err(f"unknown key (allowed: {', '.join(sorted(ENSEMBLE_KEYS))})", key)
        base_dir = Path(path).resolve().parent if path else Path.cwd()
        base: dict = {}
        if "base" in table:
            bpath = Path(table["base"])
            bpath = bpath if bpath.is_absolute() else base_dir / bpath
            try:
                btext = bpath.read_text(encoding="utf-8")
                base = tomllib.loads(btext)
            except OSError as exc:
                raise err(f"cannot read base scenario {bpath} ({exc.strerror})", "base") from None
            except tomllib.TOMLDecodeError as exc:
                raise ParseError(f"invalid TOML: {exc}", path=bpath) from None
            base = _resolve_files(base, bpath.parent)
            if "ensemble" in base:
                raise ParseError("a base scenario must not contain an [ensemble] table", path=bpath)
        _deep_merge(base, _resolve_files(data, base_dir))
        for section, value in base.items():
            if not isinstance(value, dict):
                raise ParseError(f"top-level key {section!r} outside any [section]", path=where if path else None)

        runner = table.get("runner", "closure_window")
        if not isinstance(runner, str):
            raise err("expected the name of a member runner", "runner")
        if runner in RENAMED_RUNNERS:
            import warnings

            line = _line_of(text, "runner")
            warnings.warn(f"{path or '<ensemble spec>'}" + (f", line {line}" if line else "") + f": [ensemble] runner = "
                          f"{runner!r} is deprecated; write runner = {RENAMED_RUNNERS[runner]!r}", DeprecationWarning,
                          stacklevel=2)
            runner = RENAMED_RUNNERS[runner]
        vary = table.get("vary")
        members = table.get("members")
        design = table.get("design", "members" if members is not None and vary is None else "factorial")
        if design not in ("factorial", "members"):
            raise err(f"unknown design {design!r} (factorial or members)", "design")
        params: list[Parameter] = []
        member_values: list[dict] = []
        if design == "factorial":
            if members is not None:
                raise err("give [ensemble.vary] (factorial) or [[ensemble.members]], not both", "members")
            if not isinstance(vary, dict) or not vary:
                raise err("needs [ensemble.vary] with at least one parameter (or [[ensemble.members]])", "vary")
            params = _parameters_from_vary(vary, err)
        else:
            if vary is not None:
                raise err("design 'members' takes [[ensemble.members]], not [ensemble.vary]", "vary")
            if not isinstance(members, list) or not members or not all(isinstance(m, dict) for m in members):
                raise err("needs a non-empty list of [[ensemble.members]] tables", "members")
            params, member_values = _parameters_from_members(members, err)
        names = [p.name for p in params]
        for p in params:
            try:
                p.si  # noqa: B018  (validates units)
            except (UnitError, InputError) as exc:
                raise err(str(exc), "vary" if design == "factorial" else "members") from None
            if p.name in {"member"} or not _DIM_NAME.match(p.name):
                raise err(f"bad dimension name {p.name!r}; name it with the long form (name = ...)", p.name)
        if len(set(names)) != len(names):
            raise err(f"two parameters share a dimension name: {names}")
        if len({p.path for p in params}) != len(params):
            raise err("a scenario parameter is varied twice")
        seed = table.get("seed", 0)
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise err("expected an integer", "seed")
        workers = table.get("workers")
        if workers is not None and (not isinstance(workers, int) or workers < 1):
            raise err("expected a positive integer", "workers")
        replicates = table.get("replicates", 1)
        if not isinstance(replicates, int) or isinstance(replicates, bool) or replicates < 1:
            raise err(f"expected a positive integer, got {replicates!r}", "replicates")
        if replicates > 1 and "replicate" in names:
            raise err("a varied parameter is named 'replicate', the dimension of replicates", "replicates")
        options = table.get("options", {})
        if not isinstance(options, dict):
            raise err("expected a table of runner options", "options")
        out = table.get("output")
        output = None if out is None else (Path(out) if Path(out).is_absolute() else base_dir / out)
        name = table.get("name") or (Path(path).stem if path else "ensemble")
        return cls(base=base, parameters=params, runner=runner, design=design, member_values=member_values,
                   options=options, name=str(name), description=str(table.get("description", "")), seed=seed,
                   output=output, workers=workers, scheduler=table.get("scheduler"), path=Path(path) if path else None,
                   text=text, replicates=replicates)

    # ------------------------------------------------------------------ members
    @property
    def dims(self) -> tuple[str, ...]:
        base = tuple(p.name for p in self.parameters) if self.design == "factorial" else ("member",)
        return base + (("replicate",) if self.replicates > 1 else ())

    @property
    def shape(self) -> tuple[int, ...]:
        if self.design == "factorial":
            base = tuple(len(p.values) for p in self.parameters)
        else:
            base = (len(self.member_values),)
        return base + ((self.replicates,) if self.replicates > 1 else ())

    def members(self) -> list[Member]:
        """Every member, in C order of the result grid (factorial) or in file order (members)."""
        si = {p.name: p.si[0] for p in self.parameters}
        out = []
        if self.design == "factorial":
            ranges = [range(len(p.values)) for p in self.parameters]
            for number, idx in enumerate(itertools.product(*ranges)):
                values = {p.name: p.values[i] for p, i in zip(self.parameters, idx)}
                values_si = {p.name: si[p.name][i] for p, i in zip(self.parameters, idx)}
                out.append(Member(number, idx, values, values_si))
        else:
            for number, mv in enumerate(self.member_values):
                values = {p.name: mv[p.name] for p in self.parameters}
                values_si = {p.name: si[p.name][number] for p in self.parameters}
                out.append(Member(number, (number,), values, values_si))
        context = self.fingerprint()
        for m in out:
            canon = _canonical(m.values_si)
            m.seed = member_seed(m.values_si, self.seed)
            m.key = "m-" + hashlib.sha256(f"{context}|{canon}".encode()).hexdigest()[:16]
        if self.replicates > 1:
            # common random numbers: replicate r has the same seed in every parameter combination, so a
            # parameter the closure does not depend on gives identical members along its dimension
            reps = []
            for m in out:
                for r in range(self.replicates):
                    reps.append(Member(len(reps), m.index + (r,), m.values, m.values_si,
                                       key=f"{m.key}-r{r}", seed=replicate_seed(r, self.seed), replicate=r))
            out = reps
        return out

    def member_table(self, member: Member) -> dict:
        """The member's complete scenario: the base with the member's values substituted."""
        table = copy.deepcopy(self.base)
        for p in self.parameters:
            node = table
            for part in p.path[:-1]:
                node = node.setdefault(part, {})
                if not isinstance(node, dict):
                    raise InputError(f"{p.dotted}: {part!r} is a value in the base scenario, not a table")
            node[p.path[-1]] = member.values[p.name]
        return table

    def fingerprint(self) -> str:
        """Hash of what makes two members with equal parameter values the same computation."""
        ctx = {"runner": self.runner.lower(), "options": self.options, "base": self.base,
               "parameters": [[p.name, p.dotted] for p in self.parameters]}
        return hashlib.sha256(json.dumps(ctx, sort_keys=True, default=str).encode()).hexdigest()

    def to_toml(self) -> str:
        """The spec as self-contained TOML (base inlined), for the record in the output directory."""
        ens: dict = {"name": self.name, "runner": self.runner, "design": self.design, "seed": self.seed}
        if self.replicates > 1:
            ens["replicates"] = self.replicates
        if self.description:
            ens["description"] = self.description
        if self.options:
            ens["options"] = self.options
        if self.design == "factorial":
            ens["vary"] = {p.name: {"parameter": p.dotted, "values": list(p.values),
                                    **({"long_name": p.long_name} if p.long_name else {})} for p in self.parameters}
        else:
            ens["members"] = [{p.dotted: mv[p.name] for p in self.parameters} for mv in self.member_values]
        return dump_toml({"ensemble": ens, **self.base})


def replicate_seed(replicate: int, base_seed: int = 0) -> int:
    """Seed of replicate *replicate* (63 bits, SHA-256 of the spec seed and the replicate number): the same
    in every parameter combination (common random numbers across the varied parameters)."""
    digest = hashlib.sha256(f"{int(base_seed)}|replicate|{int(replicate)}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def member_seed(values_si: dict, base_seed: int = 0) -> int:
    """Deterministic 63-bit seed of a member: SHA-256 of its canonical parameter values and the spec seed.

    Independent of the member's position, of the number of workers and of the execution order.
    """
    digest = hashlib.sha256(f"{int(base_seed)}|{_canonical(values_si)}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def _canonical(values_si: dict) -> str:
    return json.dumps({k: (repr(v) if isinstance(v, float) else v) for k, v in sorted(values_si.items())},
                      sort_keys=True)


def _parameters_from_vary(vary: dict, err) -> list[Parameter]:
    params = []

    def walk(node: dict, prefix: tuple[str, ...]):
        for key, value in node.items():
            path = prefix + tuple(str(key).split("."))
            if isinstance(value, dict) and "values" in value:
                allowed = {"values", "parameter", "name", "long_name"}
                extra = set(value) - allowed
                if extra:
                    raise err(f"unknown key(s) {sorted(extra)} in the long form (allowed: {sorted(allowed)})", key)
                target = value.get("parameter")
                ppath = tuple(str(target).split(".")) if target else path
                name = value.get("name") or ("_".join(path) if target else "_".join(ppath))
                vals = value["values"]
                if not isinstance(vals, list) or not vals:
                    raise err("values must be a non-empty list", key)
                params.append(Parameter(str(name), ppath, tuple(vals), str(value.get("long_name", ""))))
            elif isinstance(value, dict):
                walk(value, path)
            elif isinstance(value, list):
                if not value:
                    raise err("values must be a non-empty list", ".".join(path))
                params.append(Parameter("_".join(path), path, tuple(value)))
            else:
                raise err(f"expected a list of values, got {value!r}", ".".join(path))

    walk(vary, ())
    for p in params:
        if len(p.path) < 2:
            raise err(f"parameter {p.dotted!r} must be a dotted path 'section.key'", p.dotted)
        if len(set(map(_hashable, p.values))) != len(p.values):
            raise err(f"{p.dotted}: repeated value", p.dotted)
    return params


def _parameters_from_members(members: list[dict], err) -> tuple[list[Parameter], list[dict]]:
    flat = [_flatten(m) for m in members]
    keys = list(flat[0])
    for i, f in enumerate(flat):
        if set(f) != set(keys):
            raise err(f"member {i} sets {sorted(f)}, member 0 sets {sorted(keys)}: every member must set the same parameters",
                      "members")
    params = []
    for k in keys:
        path = tuple(k.split("."))
        if len(path) < 2:
            raise err(f"parameter {k!r} must be a dotted path 'section.key'", "members")
        params.append(Parameter("_".join(path), path, tuple(f[k] for f in flat)))
    values = [{p.name: f[p.dotted] for p in params} for f in flat]
    seen: dict[str, int] = {}
    for i, v in enumerate(values):
        j = seen.setdefault(_hashable(v), i)
        if j != i:
            raise err(f"member {i} repeats member {j}", "members")
    return params, values


def _flatten(node: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in node.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _hashable(v):
    """Identity of a value (or dict of values) by its SI magnitude: "20 m" and "2000 cm" are the same."""
    def si(x):
        try:
            return si_value(x, name="value")[0]
        except (InputError, UnitError):
            return x
    v = {k: si(x) for k, x in v.items()} if isinstance(v, dict) else si(v)
    return json.dumps(v, sort_keys=True, default=str)


def _deep_merge(into: dict, new: dict) -> dict:
    for k, v in new.items():
        if isinstance(v, dict) and isinstance(into.get(k), dict):
            _deep_merge(into[k], v)
        else:
            into[k] = v
    return into


def _resolve_files(node, base_dir: Path):
    """Make relative file paths absolute (strings that are not quantities and name an existing file)."""
    if isinstance(node, dict):
        return {k: _resolve_files(v, base_dir) for k, v in node.items()}
    if isinstance(node, list):
        return [_resolve_files(v, base_dir) for v in node]
    if isinstance(node, str) and not looks_like_quantity(node) and ("/" in node or "." in node):
        p = Path(node)
        if not p.is_absolute() and (base_dir / p).is_file():
            return str((base_dir / p).resolve())
    return node


def _line_of(text: str, key: str | None) -> int | None:
    if not text:
        return None
    in_ens = False
    for number, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if s.startswith("["):
            name = s.strip("[] ").split("]")[0].strip()
            in_ens = name == "ensemble" or name.startswith("ensemble.")
            if key is None and name == "ensemble":
                return number
            if key and in_ens and name.endswith("." + key):
                return number
            continue
        if key and in_ens and re.match(r'^["\']?' + re.escape(key) + r'["\']?\s*=', s):
            return number
    return None


def load_spec(path) -> EnsembleSpec:
    """Read an ensemble spec TOML file; problems are :class:`~breachflow.errors.ParseError` naming the file and line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot read ensemble spec ({exc.strerror})") from None
    return parse_spec(text, path=path)


def parse_spec(text: str, path=None) -> EnsembleSpec:
    """Parse ensemble spec TOML *text*; *path* names the file in errors and anchors relative paths."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise ParseError(f"invalid TOML: {exc}", path=path, line=int(m.group(1)) if m else None) from None
    return EnsembleSpec.from_dict(data, path=Path(path) if path else None, text=text)


def as_spec(spec) -> EnsembleSpec:
    """Accept an :class:`EnsembleSpec`, a path to a TOML file, TOML text or a dict."""
    if isinstance(spec, EnsembleSpec):
        return spec
    if isinstance(spec, dict):
        return EnsembleSpec.from_dict(spec)
    if isinstance(spec, Path) or (isinstance(spec, str) and "\n" not in spec and spec.endswith(".toml")):
        return load_spec(spec)
    if isinstance(spec, str):
        return parse_spec(spec)
    raise InputError(f"ensemble spec: expected a path, TOML text, a dict or an EnsembleSpec, got {type(spec).__name__}")


# ------------------------------------------------------------------------------------------ TOML writer
