"""Atomic file writes: a reader never sees a half-written file (write to a temp file, fsync, rename)."""
from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path, suffix: str | None = None):
    """Yield a temporary path next to *path* (same suffix, so writers that infer the format from it
    work); on success it is synced and replaces *path*, on error it is removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix or ".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write(path, write) -> Path:
    """Call ``write(tmp_path)`` and move the result to *path* atomically."""
    with atomic_path(path) as tmp:
        write(str(tmp))
    return Path(path)


def atomic_write_netcdf(ds, path, **kwargs) -> Path:
    """Write Dataset *ds* to NetCDF4 at *path* atomically (``kwargs`` go to ``to_netcdf``)."""
    return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="netcdf4", **kwargs))


def atomic_write_text(text: str, path) -> Path:
    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    return atomic_write(path, write)


def atomic_write_json(obj, path) -> Path:
    return atomic_write_text(json.dumps(obj, indent=2, sort_keys=True, default=_jsonable) + "\n", path)


def _jsonable(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
