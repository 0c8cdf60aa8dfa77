"""Atomic file writes: a reader never sees a half-written file (write to a temp file, fsync, rename).

The file gets the permissions a plain ``open()`` would give it (``0666`` minus the umask; ``mkstemp``
alone makes ``0600``). A full disk (``ENOSPC``/``EDQUOT``, or a library error such as netCDF's
``NetCDF: HDF error`` while the file system has no room left) becomes
:class:`~breachflow.errors.DiskFullError` naming the file; the temp file is removed either way.
"""
from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .errors import DiskFullError


@contextmanager
def atomic_path(path, suffix: str | None = None):
    """Yield a temporary path next to *path* (same suffix, so writers that infer the format from it
    work); on success it is synced and replaces *path*, on error it is removed."""
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix or ".tmp", dir=path.parent)
        os.close(fd)
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~current_umask())
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        full = _disk_full(exc, path.parent)
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        if full:
            raise DiskFullError(path, full) from exc
        raise


#: a library error while writing counts as a full disk when less than this is left free
NEARLY_FULL = 64 * 1024


def _disk_full(exc: BaseException, folder: Path) -> str:
    """Why *exc* is a full disk ("" when it is not): an ``ENOSPC``/``EDQUOT`` anywhere in its chain, or an
    error from a library that hides the errno (netCDF's "HDF error") while *folder*'s file system is full."""
    if isinstance(exc, DiskFullError):
        return ""
    e = exc
    while e is not None:
        if isinstance(e, OSError) and e.errno in (errno.ENOSPC, errno.EDQUOT):
            return os.strerror(e.errno)
        e = e.__cause__ or e.__context__
    if isinstance(exc, (OSError, RuntimeError)):
        try:
            free = shutil.disk_usage(folder).free
        except OSError:
            return ""
        if free < NEARLY_FULL:
            return f"{type(exc).__name__}: {exc}; {free} bytes free"
    return ""


def current_umask() -> int:
    """The process umask (``os.umask`` can only be read by setting it; it is set straight back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write(path, write) -> Path:
    """Call ``write(tmp_path)`` and move the result to *path* atomically."""
    with atomic_path(path) as tmp:
        write(str(tmp))
    return Path(path)


def atomic_write_netcdf(ds, path, *, provenance: bool = True, **kwargs) -> Path:
    """Write Dataset *ds* to NetCDF4 at *path* atomically (``kwargs`` go to ``to_netcdf``), with the
    provenance attributes of :func:`breachflow.provenance.stamp` unless *provenance* is False."""
    if provenance:
        from .provenance import stamp

        ds = stamp(ds)
    return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="netcdf4", **kwargs))


def atomic_write_text(text: str, path) -> Path:
    """Write *text* (UTF-8) to *path* atomically."""

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    return atomic_write(path, write)


def atomic_write_json(obj, path, *, indent: int = 2, default=None) -> Path:
    """Write *obj* as JSON (sorted keys, *indent*) to *path* atomically; *default* turns values JSON does not
    know into ones it does (numpy scalars and arrays, paths by default)."""
    return atomic_write_text(json.dumps(obj, indent=indent, sort_keys=True, default=default or _jsonable) + "\n", path)


def _jsonable(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
