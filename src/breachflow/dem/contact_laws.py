"""The particle contact laws of the DEM, chosen by name from the registry ``breachflow.contact_laws``
(``DemSimulation(contact_law=...)``); both are the linear spring–dashpot with Coulomb friction and shear
history of docs/theory.md, *DEM contact*, computed differently:

* ``"window_averaged"`` (default) — :func:`.contact_law.contact_law`: the law averaged over the
  integrator's force window, so contact onset and release inside a step are resolved (issue 12), the
  shear history turned into the tangent plane with its length kept, the Coulomb limit on the spring;
* ``"hooke_history"`` — :func:`.contact_law.hooke_history`: LAMMPS ``pair_style gran/hooke/history``
  exactly (point values at the evaluation time, history projected into the tangent plane, Coulomb limit on
  the spring + dashpot force), for like-for-like comparisons with LAMMPS (``benchmarks/bench_dem.py``).
  Less accurate where a contact begins or ends inside a step: at the default step its coefficient of
  restitution depends on the onset phase (tests/dem/test_contact_laws.py gives the measured spread).

The compiled contact kernels hold both laws and select one by the class attribute ``code`` (a plug-in registered here
cannot add a third without a kernel for it). Rolling resistance (:func:`.contact_law.rolling_law`) and the
boundaries use the chosen law too.
"""
from __future__ import annotations

import numpy as np

from ..registry import Registry
from .contact_law import HOOKE_HISTORY, WINDOW_AVERAGED, contact_law, hooke_history

contact_laws: Registry = Registry("DEM contact law", "breachflow.contact_laws")


def _props(kn, ks, c_cn, c_cs, c_cf, alpha, beta):
    return float(kn), float(ks), float(c_cn), float(c_cs), float(c_cf), float(alpha), float(beta)


@contact_laws.register("window_averaged")
class WindowAveraged:
    """The default law, averaged over the force window ``[lo, hi]`` (:func:`.contact_law.contact_law`)."""

    code = WINDOW_AVERAGED

    def force(self, n, overlap, v, g, hist, kn, ks, c_cn, c_cs, c_cf, alpha, beta, dt, lo=0.0, hi=0.0):
        """Force (on the particle n points away from) of one contact with history *hist* (3,), updated in
        place; returns (window fraction in contact, force (3,), tangential force (3,), compressive ``|f_N|``)."""
        h = np.asarray(hist, float).reshape(1, 3)
        kn, ks, c_cn, c_cs, c_cf, alpha, beta = _props(kn, ks, c_cn, c_cs, c_cf, alpha, beta)
        r = contact_law(*map(float, n), float(overlap), *map(float, v), *map(float, g), h, 0, kn, ks, c_cn, c_cs,
                        c_cf, alpha, beta, float(dt), float(lo), float(hi))
        hist[:] = h[0]
        return r[0], np.array(r[1:4]), np.array(r[4:7]), r[7]


@contact_laws.register("hooke_history")
class HookeHistory(WindowAveraged):
    """LAMMPS ``gran/hooke/history`` at points (:func:`.contact_law.hooke_history`; ``c_cf`` unused)."""

    code = HOOKE_HISTORY

    def force(self, n, overlap, v, g, hist, kn, ks, c_cn, c_cs, c_cf, alpha, beta, dt, lo=0.0, hi=0.0):
        """As :meth:`WindowAveraged.force`, at the evaluation time (*lo*, *hi* ignored; *overlap* > 0)."""
        h = np.asarray(hist, float).reshape(1, 3)
        kn, ks, c_cn, c_cs, c_cf, alpha, beta = _props(kn, ks, c_cn, c_cs, c_cf, alpha, beta)
        r = hooke_history(*map(float, n), float(overlap), *map(float, v), *map(float, g), h, 0, kn, ks, c_cn, c_cs,
                          alpha, beta, float(dt))
        hist[:] = h[0]
        return r[0], np.array(r[1:4]), np.array(r[4:7]), r[7]


def resolve(law) -> object:
    """A contact-law instance from a registry name or an instance; InputError for an unknown name or a
    law without a kernel code."""
    from ..errors import InputError

    obj = contact_laws.get(law)() if isinstance(law, str) else law
    if getattr(obj, "code", None) not in (WINDOW_AVERAGED, HOOKE_HISTORY):
        raise InputError(f"contact law {law!r} has no compiled kernel (choose one of: window_averaged, "
                         f"hooke_history)")
    return obj
