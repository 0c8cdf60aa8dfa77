"""Suite-wide settings for running the tests in parallel (``python3 tasks.py test`` runs pytest-xdist:
``-n <cores> --dist loadfile``, the tests of one file in one worker, so a module-scoped fixture is computed once).

* The workers share numba's on-disk cache (``NUMBA_CACHE_DIR``, filled by the install warm-up). numba writes
  each cache file atomically (a unique temporary file, then ``os.replace``), but adding an entry reads the
  function's index, picks the next free data-file number and writes both back without a lock: two processes
  that compile *different* signatures of one function at the same moment can both pick number ``n``, and the
  index left behind may then point one signature at the other's machine code. Saving is serialised in every
  worker (:func:`breachflow.numba_cache.serialise_cache_saves`, as the ensemble's workers do).
* An xdist worker starts with ``COLUMNS=80`` and ``LINES=24`` in its environment even when the run has none;
  the CLI's console wraps piped output at ``$COLUMNS`` (``breachflow.cli._common``), so paths and messages
  the tests look for were broken over lines in a worker only. Each worker gets the run's own values back.
"""
import os

import pytest


if os.environ.get("PYTEST_XDIST_WORKER"):
    from breachflow.numba_cache import serialise_cache_saves

    serialise_cache_saves()


#: environment variables a worker takes from the run that started it (None: unset)
TERMINAL_ENV = ("COLUMNS", "LINES")


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """xdist, in the controller: hand this run's terminal settings to the worker."""
    node.workerinput["breachflow_env"] = {k: os.environ.get(k) for k in TERMINAL_ENV}


def pytest_configure(config):
    for k, v in getattr(config, "workerinput", {}).get("breachflow_env", {}).items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def pytest_sessionfinish(session):
    """With ``BREACHFLOW_TEST_CPU_LOG=FILE``: append this process's CPU seconds (and those of the subprocesses
    its tests started) to FILE, one line per xdist worker — how evenly the work was spread."""
    log = os.environ.get("BREACHFLOW_TEST_CPU_LOG")
    if log:
        import resource

        me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
        with open(log, "a") as f:
            f.write(f"{os.environ.get('PYTEST_XDIST_WORKER', 'controller')}: {me.ru_utime + me.ru_stime:.1f} CPU s, "
                    f"subprocesses {kids.ru_utime + kids.ru_stime:.1f} CPU s\n")
