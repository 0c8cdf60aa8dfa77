"""Machine-readable Dataset schemas (``data_schemas/*.json``) and their validator.

Every Dataset breachflow reads or writes has a schema; readers and writers call :func:`validate`.
A schema is JSON of this form::

    {
      "name": "snapshot_grid",
      "description": "...",
      "global_attributes": {"Conventions": {"pattern": "CF-1\\\\.\\\\d+"}, "source_files": {}},
      "coordinates": {"x": {"dims": [["x"]], "units": "m", "attributes": {"standard_name": "projection_x_coordinate"}}},
      "variables": {
        "depth": {"dims": [["y", "x"], ["time", "y", "x"]], "units": "m", "dtype": "floating",
                  "attributes": {"standard_name": "sea_floor_depth_below_sea_surface", "long_name": null},
                  "required": true, "min": 0}
      }
    }

``dims`` lists the allowed dimension tuples; ``units`` must equal ``attrs["units"]``; ``dtype`` is a numpy
kind name (``floating``, ``integer``, ``bool``, ``str``); an attribute value of ``null`` means "present,
any value", a string value means "exactly this", ``{"pattern": re}`` a regular expression.
``required`` defaults to true.
"""
from __future__ import annotations

import json
import re
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np

from .errors import SchemaError


def schema_dirs() -> list[Path]:
    """Where schemas are looked up: the source tree's ``data_schemas/`` then the installed copy."""
    here = Path(__file__).resolve()
    return [here.parents[2] / "data_schemas", Path(sys.prefix) / "share" / "breachflow" / "data_schemas"]


@lru_cache(maxsize=None)
def load_schema(name: str) -> dict:
    """Load the schema called *name* (file ``data_schemas/<name>.json``)."""
    for d in schema_dirs():
        p = d / f"{name}.json"
        if p.exists():
            return json.loads(p.read_text())
    raise SchemaError(f"no schema named {name!r} in {', '.join(map(str, schema_dirs()))}")


def available_schemas() -> list[str]:
    names: set[str] = set()
    for d in schema_dirs():
        if d.is_dir():
            names.update(p.stem for p in d.glob("*.json"))
    return sorted(names)


_KINDS = {"floating": np.floating, "integer": np.integer, "bool": np.bool_, "str": (np.str_, np.object_),
          "datetime": np.datetime64, "number": np.number}


def _check_attrs(where: str, attrs: dict, spec: dict, problems: list[str]) -> None:
    for key, want in (spec or {}).items():
        optional = isinstance(want, dict) and want.get("required") is False
        if key not in attrs:
            if not optional:
                problems.append(f"{where}: missing attribute {key!r}")
            continue
        have = attrs[key]
        if isinstance(want, str) and str(have) != want:
            problems.append(f"{where}: attribute {key!r} is {have!r}, expected {want!r}")
        elif isinstance(want, dict) and "pattern" in want and not re.fullmatch(want["pattern"], str(have)):
            problems.append(f"{where}: attribute {key!r}={have!r} does not match {want['pattern']!r}")


def _check_var(where: str, da, spec: dict, problems: list[str]) -> None:
    allowed = [tuple(d) for d in spec.get("dims", [])]
    if allowed and tuple(da.dims) not in allowed:
        problems.append(f"{where}: dims {tuple(da.dims)} not among {allowed}")
    if "units" in spec and da.attrs.get("units", da.encoding.get("units")) != spec["units"]:
        problems.append(f"{where}: units {da.attrs.get('units')!r}, expected {spec['units']!r}")
    kinds = _KINDS.get(spec.get("dtype"), ())
    kinds = kinds if isinstance(kinds, tuple) else (kinds,)
    if "dtype" in spec and not any(np.issubdtype(da.dtype, k) for k in kinds):
        problems.append(f"{where}: dtype {da.dtype} is not {spec['dtype']}")
    attrs = dict(da.attrs)
    for key in ("coordinates", "units", "calendar"):  # xarray moves these into .encoding on read
        if key not in attrs and key in da.encoding:
            attrs[key] = da.encoding[key]
    _check_attrs(where, attrs, spec.get("attributes", {}), problems)
    if ("min" in spec or "max" in spec) and np.issubdtype(da.dtype, np.number) and da.size:
        vals = np.asarray(da.values)
        finite = vals[np.isfinite(vals)] if np.issubdtype(vals.dtype, np.floating) else vals.ravel()
        if finite.size and "min" in spec and finite.min() < spec["min"]:
            problems.append(f"{where}: minimum {finite.min():g} below {spec['min']:g}")
        if finite.size and "max" in spec and finite.max() > spec["max"]:
            problems.append(f"{where}: maximum {finite.max():g} above {spec['max']:g}")
    if spec.get("finite") and np.issubdtype(da.dtype, np.floating) and not np.all(np.isfinite(da.values)):
        problems.append(f"{where}: contains NaN or inf")


def validate(ds, schema: str | dict, *, source: str | None = None):
    """Check Dataset *ds* against *schema* (a name or a dict); return *ds* or raise :class:`~breachflow.errors.SchemaError`.

    The error lists every problem found, prefixed by *source* (a file name) when given.
    """
    spec = load_schema(schema) if isinstance(schema, str) else schema
    problems: list[str] = []
    _check_attrs("global", ds.attrs, spec.get("global_attributes", {}), problems)
    for group in ("coordinates", "variables"):
        for name, vspec in spec.get(group, {}).items():
            if name not in ds.variables:
                if vspec.get("required", True):
                    problems.append(f"{name}: missing {group[:-1]}")
                continue
            _check_var(name, ds[name], vspec, problems)
    if problems:
        head = f"{source}: " if source else ""
        raise SchemaError(f"{head}Dataset does not match schema {spec.get('name', '?')!r}:\n  - " + "\n  - ".join(problems))
    return ds
