"""breachflow — levee-breach closure simulation.

Closure-window arithmetic and breach growth (:mod:`breachflow.scenario`), hydrodynamic snapshots and the
embedded shallow-water solver (:mod:`breachflow.field`), the discrete element method for dropped masses
(:mod:`breachflow.dem`), the closure cycle (:mod:`breachflow.cycle`) and ensembles
(:mod:`breachflow.ensemble`). The equations and their sources: docs/theory.md.
"""
from __future__ import annotations

from .numba_cache import configure_cache_dir as _configure_cache_dir

_configure_cache_dir()  # the kernels warmed by tasks.py, wherever the program is started from

from .errors import BreachflowError, DiskFullError, InputError, ParseError, SchemaError, UnitError, PhysicsError  # noqa: E402
from .units import ureg, Q_, to_si  # noqa: E402

__version__ = "0.2.0"



def __getattr__(name):
    # lazy: importing the readers (numba kernels) only when asked for
    if name == "open_snapshot":
        from .io import open_snapshot

        return open_snapshot
    raise AttributeError(f"module 'breachflow' has no attribute {name!r}")


__all__ = ["open_snapshot", 
    "BreachflowError", "DiskFullError", "InputError", "ParseError", "SchemaError", "UnitError", "PhysicsError",
    "ureg", "Q_", "to_si", "__version__",
]
