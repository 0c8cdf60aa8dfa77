"""The scenario-file reference, generated from the parsers: ``data_schemas/scenario.json`` (a JSON schema
of the scenario TOML) and ``docs/scenario_reference.md``.

Every registered section's ``from_table`` is run against a recording :class:`~breachflow.scenario.config.SectionContext`: the keys it
allows (``check_keys``), and for each key the converter it calls — ``quantity`` (kind, SI unit, default,
default unit, sign), ``raw`` (TOML types, default) or ``file``. Sections that parse without the context
(``[placement]``, ``[criteria]``) describe their keys with a ``schema_keys()`` class method drawn from the
code that parses them. Regenerate after changing a section::

    python -m breachflow.scenario.reference          # writes both files
    python -m breachflow.scenario.reference --check  # exit 1 when they are out of date (the tests do this)
"""
from __future__ import annotations

import inspect
import json
import sys
from pathlib import Path

from ..units import SI_UNITS
from .config import SectionContext, sections

ROOT = Path(__file__).resolve().parents[3]
SCHEMA_PATH = ROOT / "data_schemas" / "scenario.json"
MARKDOWN_PATH = ROOT / "docs" / "scenario_reference.md"
_JSON_TYPES = {str: "string", int: "integer", float: "number", bool: "boolean", list: "array", dict: "object"}


def quantity_schema(kind: str, *, default=None, default_unit=None, positive=False, nonnegative=False,
                    sweep=True) -> dict:
    """Schema of a quantity key: a string with units (``"2.8 m"``), a bare number when the kind has a
    default unit, or a list of them (a sweep)."""
    unit = SI_UNITS.get(kind, kind)
    one = [{"type": "string", "pattern": r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*\S*.*$"}]
    if default_unit is not None:
        one.append({"type": "number"})
    spec = {"anyOf": one + ([{"type": "array", "items": {"anyOf": one}, "minItems": 1}] if sweep else []),
            "x-kind": kind, "x-si-unit": unit or "1"}
    if default is not None:
        spec["default"] = default
    if default_unit is not None:
        spec["x-default-unit"] = default_unit or "1"
    if positive:
        spec["x-constraint"] = "> 0"
    elif nonnegative:
        spec["x-constraint"] = ">= 0"
    return spec


class _Probe(SectionContext):
    """A SectionContext that records what a section parser asks for and never fails."""

    def __init__(self, section: str):
        super().__init__(None, "", section)
        self.allowed: set[str] = set()
        self.subtables: set[str] = set()
        self.keys: dict[str, dict] = {}

    def check_keys(self, table, allowed, *, subtables=()):
        self.allowed |= set(allowed)
        self.subtables |= set(subtables)

    def quantity(self, table, key, kind, *, required=False, default=None, default_unit=None, positive=False,
                 nonnegative=False, dim=None):
        spec = quantity_schema(kind, default=default, default_unit=default_unit, positive=positive,
                               nonnegative=nonnegative)
        if required:
            spec["x-required"] = True
        self.keys.setdefault(key, spec)
        return 1.0 if default is None else default

    def raw(self, table, key, *, types=(str,), required=False, default=None):
        names = sorted({_JSON_TYPES.get(t, "string") for t in types})
        spec = {"type": names[0] if len(names) == 1 else names}
        if default is not None and not (isinstance(default, list) and not default):
            spec["default"] = default
        if required:
            spec["x-required"] = True
        self.keys.setdefault(key, spec)
        if default is not None:
            return default
        return {str: "", int: 0, bool: False, list: [], float: 0.0}.get(types[0], "")

    def file(self, table, key):
        self.keys.setdefault(key, {"type": "string", "x-kind": "path (relative to the scenario file)"})
        return None


def _doc(cls) -> str:
    text = inspect.getdoc(cls) or ""
    return " ".join(text.split("\n\n")[0].split())


def section_schema(name: str) -> dict:
    """JSON schema of the table ``[name]`` as its registered parser reads it."""
    cls = sections.get(name)
    probe = _Probe(name)
    if hasattr(cls, "schema_keys"):
        probe.keys = dict(cls.schema_keys())
        probe.allowed = set(probe.keys)
    else:
        for table in ({}, None):  # first learn the keys, then ask for each of them
            if table is None:
                table = {k: None for k in probe.allowed}
            try:
                cls.from_table(table, probe)
            except Exception:  # a probe value that the section's own checks refuse: what was asked is recorded
                pass
    if hasattr(cls, "extra_schema_keys"):  # keys a section reads through a helper, described by it
        probe.keys.update(cls.extra_schema_keys())
    props = {k: probe.keys.get(k, {"description": "see the section description"}) for k in sorted(probe.allowed)}
    if hasattr(cls, "schema_defaults"):  # sections whose defaults live where the values are used
        for k, v in cls.schema_defaults().items():
            if k in props:
                props[k] = {**props[k], "default": v}
    for sub in sorted(probe.subtables):
        props[sub] = {"type": "object", "description": f"sub-table [{name}.{sub}]"}
    return {"type": "object", "description": _doc(cls), "properties": props, "additionalProperties": False}


def scenario_schema() -> dict:
    """The JSON schema of a scenario file: one property per registered section."""
    names = sorted(sections.available())
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://breachflow.invalid/data_schemas/scenario.json",
        "title": "breachflow scenario file (TOML)",
        "description": ("Generated by `python -m breachflow.scenario.reference` from the section parsers; do not edit. "
                        "Quantities are strings with units (x-kind: the dimension, x-si-unit: the unit used inside); "
                        "a list of quantities sweeps a dimension."),
        "type": "object",
        "properties": {n: section_schema(n) for n in names},
        "additionalProperties": False,
    }


def _cell(v) -> str:
    if v is None:
        return ""
    text = json.dumps(v) if not isinstance(v, str) else v
    return text.replace("|", "\\|")


def markdown(schema: dict) -> str:
    """The Markdown reference of *schema*: a table of keys per section."""
    lines = ["# Scenario file reference", "",
             "Generated by `python -m breachflow.scenario.reference` from the section parsers (the same run writes",
             "`data_schemas/scenario.json`); do not edit. Quantities are strings with units (`\"2.8 m\"`, `\"40 cm/hr\"`);",
             "*kind* is the dimension they must have, *SI unit* the unit they are converted to. A bare number is",
             "accepted only where a default unit is listed; a list of quantities sweeps a dimension.", ""]
    for name, sec in schema["properties"].items():
        lines += [f"## [{name}]", "", sec["description"] or "", "",
                  "| key | type | kind | SI unit | default | constraint |", "|---|---|---|---|---|---|"]
        for key, p in sec["properties"].items():
            if "anyOf" in p:
                typ = "quantity" + (" or number" if "x-default-unit" in p else "")
            else:
                typ = p.get("type", "")
                typ = " or ".join(typ) if isinstance(typ, list) else typ
            lines.append(f"| `{key}` | {typ} | {_cell(p.get('x-kind'))} | {_cell(p.get('x-si-unit'))} | "
                         f"{_cell(p.get('default'))} | {_cell(p.get('x-constraint') or ('required' if p.get('x-required') else ''))} |")
            for alt in p.get("anyOf", []):  # the keys of a keyword table (e.g. a criterion's), as key.sub
                for sub, q in alt.get("properties", {}).items():
                    styp = ("quantity" + (" or number" if "x-default-unit" in q else "")) if "anyOf" in q else q.get("type", "")
                    lines.append(f"| `{key}.{sub}` | {styp} | {_cell(q.get('x-kind'))} | {_cell(q.get('x-si-unit'))} | "
                                 f"{_cell(q.get('default'))} | {_cell(q.get('description'))} |")
        lines.append("")
    return "\n".join(lines)


def render() -> tuple[str, str]:
    schema = scenario_schema()
    return json.dumps(schema, indent=2, sort_keys=False) + "\n", markdown(schema)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    js, md = render()
    if "--check" in argv:
        stale = [str(p) for p, text in ((SCHEMA_PATH, js), (MARKDOWN_PATH, md))
                 if not p.exists() or p.read_text() != text]
        if stale:
            print("out of date (run python -m breachflow.scenario.reference): " + ", ".join(stale))
            return 1
        return 0
    SCHEMA_PATH.write_text(js)
    MARKDOWN_PATH.parent.mkdir(exist_ok=True)
    MARKDOWN_PATH.write_text(md)
    print(f"wrote {SCHEMA_PATH} and {MARKDOWN_PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
