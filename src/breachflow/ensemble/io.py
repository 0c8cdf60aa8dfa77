"""Ensemble records on disk: written atomically with :mod:`breachflow.atomic` (:func:`write_record`), read back
with :func:`read_json`."""
from __future__ import annotations

import json
from pathlib import Path

from ..atomic import atomic_write_json


def write_record(path, data) -> Path:
    """Write the JSON record *data* (a member's result) to *path* atomically: one space indent, sorted keys,
    values JSON does not know written as their ``str``."""
    return atomic_write_json(data, path, indent=1, default=str)


def read_json(path) -> dict | None:
    """The JSON object in *path*, or None when it is missing or unreadable (a crashed write never leaves a
    partial file, but a hand-edited or foreign file might be broken)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
