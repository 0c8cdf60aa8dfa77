"""Atomic file writes for ensemble outputs: a temp file in the target directory, then ``os.replace``."""
from __future__ import annotations

import json
import os
from pathlib import Path

from ..atomic import atomic_path


def atomic_write_text(path, text: str) -> Path:
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
    return Path(path)


def atomic_write_json(path, data) -> Path:
    return atomic_write_text(path, json.dumps(data, indent=1, sort_keys=True, default=str) + "\n")


def read_json(path) -> dict | None:
    """The JSON object in *path*, or None when it is missing or unreadable (a crashed write never leaves a
    partial file, but a hand-edited or foreign file might be broken)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
