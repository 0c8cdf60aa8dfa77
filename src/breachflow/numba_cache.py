"""Several processes compiling into one numba on-disk cache (``cache=True``; ``NUMBA_CACHE_DIR``).

numba writes each cache file atomically (a unique temporary file, then ``os.replace``), but adding an entry
reads the function's index, picks the next free data-file number and writes both back without a lock: two
processes that compile *different* signatures of one function at the same moment can both pick number ``n``,
and the index left behind may then point one signature at the other's machine code (numba issues #4807, a
segfault with dask workers sharing a cache, and #10128, where the maintainers suggest a file lock). This
happens to the workers of an ensemble (:mod:`breachflow.ensemble`) and of the parallel test run when the cache
is not yet filled. :func:`serialise_cache_saves` makes every save of this process take an exclusive ``flock``
on a lock file beside the index (tests/test_parallel_suite.py: two processes saving 300 entries each keep all
600 with their own data; numba's own save kept 568, 13 pointing at the other's data).

Where the cache is: :func:`source_cache_dir` — in a source checkout, ``.numba_cache/<hash>`` beside
``pyproject.toml``, one folder per state of the sources (numba checks only the file of the function it
caches, so a kernel that inlines a helper from another module would keep a stale build after that helper
changes). ``tasks.py`` warms it, and :func:`configure_cache_dir` (run when :mod:`breachflow` is imported)
points numba at the same folder, so ``.venv/bin/breachflow`` started from any directory uses the warmed
kernels. ``NUMBA_CACHE_DIR``, when set, wins; an installed package keeps numba's default (``__pycache__``
beside the sources).

Any edit of a source file gives a new, empty folder, so ``tasks.py`` warms a folder whenever it lacks the
:data:`WARMED` file that :func:`mark_warmed` writes after a successful warm-up (``python -m breachflow.warmup``),
not only after installing; :func:`warm_up_lock` keeps two ``tasks.py`` started at once from compiling the
same kernels twice. Without this, a run after a source edit compiled its kernels on first use: about
85 CPU s in its first DEM cycle (docs/verdict-check.md).

This module imports only the standard library: ``tasks.py`` loads it by path, before any environment exists.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import sys
from pathlib import Path

#: the package's folder (``src/breachflow`` in a checkout)
PACKAGE = Path(__file__).resolve().parent


def checkout_root(package: Path = PACKAGE) -> Path | None:
    """The source checkout the package runs from (the folder with ``pyproject.toml`` above ``src/``), or None
    for an installed package."""
    root = package.parent.parent
    if package.parent.name == "src" and (root / "pyproject.toml").is_file():
        return root
    return None


def source_cache_dir(root: Path, *, prune: bool = False) -> Path:
    """numba's cache folder for the sources under *root*: ``root/.numba_cache/<first 16 hex of the sha256 of
    every src/breachflow/**.py, path and bytes>``. With *prune*, folders of earlier source states are removed."""
    h = hashlib.sha256()
    for f in sorted((root / "src" / "breachflow").rglob("*.py")):
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes())
    base = root / ".numba_cache"
    here = base / h.hexdigest()[:16]
    if prune and base.is_dir() and not here.is_dir():
        for old in base.iterdir():
            if old.is_dir():
                shutil.rmtree(old, ignore_errors=True)
    return here


#: the file in a cache folder that says the warm-up filled it (:func:`mark_warmed`)
WARMED = "warmed.txt"


def is_warmed(folder) -> bool:
    """Whether the warm-up filled the cache folder *folder* (its :data:`WARMED` file exists)."""
    return (Path(folder) / WARMED).is_file()


def mark_warmed(folder, note: str = "") -> None:
    """Record in *folder* that the warm-up filled it (*note*: a line for people, e.g. its CPU time)."""
    Path(folder).mkdir(parents=True, exist_ok=True)
    (Path(folder) / WARMED).write_text(note + "\n", encoding="utf-8")


@contextlib.contextmanager
def warm_up_lock(folder):
    """Hold an exclusive lock (POSIX ``flock``; none elsewhere) on ``warmup.lock`` beside the cache folder
    *folder* while it is checked and warmed."""
    base = Path(folder).parent
    base.mkdir(parents=True, exist_ok=True)
    try:
        import fcntl
    except ImportError:
        yield
        return
    with open(base / "warmup.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def configure_cache_dir() -> str | None:
    """Point numba at the checkout's warmed cache unless ``NUMBA_CACHE_DIR`` is set; returns the folder used
    (None: numba's default). Works before and after numba is imported."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    root = checkout_root()
    if root is None:
        return None
    try:
        here = str(source_cache_dir(root))
    except OSError:
        return None
    os.environ["NUMBA_CACHE_DIR"] = here  # read by numba at import, and inherited by worker processes
    config = sys.modules.get("numba.core.config")
    if config is not None:
        config.CACHE_DIR = here
    return here


def serialise_cache_saves() -> bool:
    """Serialise this process's numba cache saves across processes (POSIX ``flock``); idempotent. Returns
    False where there is nothing to patch (no ``fcntl``, or a numba without ``IndexDataCacheFile``)."""
    try:
        import fcntl

        from numba.core.caching import IndexDataCacheFile
    except ImportError:
        return False
    save = IndexDataCacheFile.save
    if getattr(save, "_breachflow_locked", False):
        return True

    def locked_save(self, key, data):
        os.makedirs(os.path.dirname(self._index_path), exist_ok=True)
        with open(self._index_path + ".lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                save(self, key, data)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)

    locked_save._breachflow_locked = True
    IndexDataCacheFile.save = locked_save
    return True
