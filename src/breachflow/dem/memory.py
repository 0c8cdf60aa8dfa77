"""Memory hooks: what a DEM run carries besides the particles takes part in ``save_state`` / ``from_state``.

An integrator or force model with a memory (the step-size controller of ``adaptive_free_flight``, the
Basset history of ``FluidForces(basset=True)``) has two methods:

* ``state_arrays() -> dict[str, np.ndarray]`` — its memory, with the same names whatever has happened
  (so a fresh object's names say what a restore needs);
* ``restore_state(arrays)`` — take such a dict back (the object passed again to ``from_state``).

Objects without them have no memory. :func:`save` and :func:`restore` store the arrays under a prefix
(``integrator.``, ``model<k>.``); :func:`restore` refuses entries missing or left over with an
:class:`~breachflow.errors.InputError` naming them.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError


def names(obj) -> set[str]:
    """Names of *obj*'s memory arrays (empty without the hook)."""
    hook = getattr(obj, "state_arrays", None)
    return set() if hook is None else set(hook())


def save(obj, prefix: str, out: dict) -> None:
    """Copy *obj*'s memory into *out* as ``prefix + name``."""
    hook = getattr(obj, "state_arrays", None)
    for name, a in ({} if hook is None else hook()).items():
        out[prefix + name] = np.array(a, copy=True)


def restore(obj, prefix: str, data, what: str) -> None:
    """Give *obj* (described as *what* in errors) its memory from the ``prefix + name`` entries of *data*."""
    want = names(obj)
    have = {k[len(prefix):] for k in data if k.startswith(prefix)}
    if want - have:
        raise InputError(f"DEM state lacks {_listed(prefix, want - have)} that {what} {obj!r} needs "
                         "(saved with a different one?)")
    if have - want:
        raise InputError(f"DEM state holds {_listed(prefix, have - want)} that {what} {obj!r} does not keep "
                         "(restore with the one it was saved with)")
    if want:
        obj.restore_state({n: np.array(data[prefix + n], copy=True) for n in want})


def _listed(prefix, names_):
    return ", ".join(prefix + n for n in sorted(names_))
