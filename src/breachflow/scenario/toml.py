"""Scenario TOML text: a minimal writer and dotted-key changes of a scenario (ensembles, pipelines, tests).

:func:`scenario_with` is how scripts over scenario grids derive a variant from a base scenario::

    text = scenario_with(base, {"criteria.max_cycles": 3, "placement.positions": "vertical",
                                "placement.start": None})   # None drops the key
"""
from __future__ import annotations

import json
import math
import re
import tomllib
from typing import Any

from ..errors import InputError

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def scenario_with(text: str, changes: dict[str, Any]) -> str:
    """Scenario *text* with the values of *changes* set: keys are dotted paths ``section.key`` (tables are
    created as needed; a value ``None`` removes the key). Returns TOML text (:func:`dump_toml`)."""
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"scenario text: {exc}") from None
    for dotted, value in changes.items():
        *path, key = dotted.split(".")
        if not path:
            raise InputError(f"scenario change {dotted!r}: expected a dotted path 'section.key'")
        node = table
        for part in path:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise InputError(f"scenario change {dotted!r}: {part!r} is not a table")
        if value is None:
            node.pop(key, None)
        else:
            node[key] = value
    return dump_toml(table)


def dump_toml(data: dict, sections: list[str] | None = None) -> str:
    """Minimal TOML writer for scenario tables (scalars, lists, nested tables). Each top-level table is a
    self-contained block, so the text of a subset of *sections* is a prefix of the text of all of them
    when those come first (line numbers in parse errors stay right)."""
    order = list(sections) if sections is not None else list(data)
    blocks = []
    for name in order:
        value = data[name]
        if not isinstance(value, dict):
            raise InputError(f"scenario: top-level key {name!r} is not a table")
        blocks.append(_dump_table((name,), value))
    return "\n".join(blocks)


def _dump_table(path: tuple[str, ...], table: dict) -> str:
    lines = [f"[{'.'.join(_key(p) for p in path)}]"]
    subs = []
    arrays_of_tables = []
    for k, v in table.items():
        if isinstance(v, dict):
            subs.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays_of_tables.append((k, v))
        else:
            lines.append(f"{_key(k)} = {_value(v)}")
    text = "\n".join(lines) + "\n"
    for k, v in subs:
        text += "\n" + _dump_table(path + (k,), v)
    for k, items in arrays_of_tables:
        for item in items:
            head = f"[[{'.'.join(_key(p) for p in path + (k,))}]]"
            body = "\n".join(f"{_key(a)} = {_value(b)}" for a, b in item.items())
            text += f"\n{head}\n{body}\n"
    return text


def _key(k: str) -> str:
    return k if _BARE_KEY.match(k) else json.dumps(k)


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(a)} = {_value(b)}" for a, b in v.items()) + "}"
    if hasattr(v, "isoformat"):
        return v.isoformat()
    raise InputError(f"cannot write {v!r} to TOML")


_TABLE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")


def line_of(text: str, section: str, key: str | None) -> int | None:
    """1-based line of ``[section]`` (key None) or of ``key =`` inside it; dotted sections allowed."""
    if not text:
        return None
    current = ""
    key_re = re.compile(r'^\s*["\']?' + re.escape(key) + r'["\']?\s*=') if key else None
    for number, line in enumerate(text.splitlines(), start=1):
        m = _TABLE.match(line)
        if m:
            current = m.group(1).replace(" ", "")
            if key is None and current == section:
                return number
            continue
        if key_re is not None and current == section and key_re.match(line):
            return number
    return None
