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
"""
from __future__ import annotations

import os


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
