"""Warm re-solve over the whole domain started from a coarse grid's answer (a two-grid correction).

After a cycle's pile is placed, most of the warm re-solve's simulated time goes into the slowest mode of
the flow: the flood-side pool rising as the pile cuts the breach discharge, a change spread over the whole
pool that settles on the time a long wave needs to cross it and come back. The same response on cells
``factor`` times larger costs about ``factor³`` less. ``[hydro] resolve = "coarse"``:

1. the domain with the pile and the domain as it was before it are both laid on the coarse grid
   (:func:`breachflow.hydro.far_field.coarse_domain`: bed averaged over the open fine cells, the pile
   averaged) and solved to steady state there (:class:`breachflow.hydro.far_field.CoarseFarField`; the
   coarse state "before" of one re-solve is kept for the next one);
2. the difference of the two coarse water levels — the coarse model's response to the pile, its own
   bias against the fine grid cancelling to first order — is interpolated to the fine cells and added
   to the previous fine steady state on its wet cells (velocities kept);
3. the fine grid is re-solved over the whole domain from there with the same steady-state test as
   ``resolve = "full"`` (tolerance, monitored region, breach discharge), so the answer is the fine
   grid's steady state within that tolerance; the coarse level only shortens the way there.

The first (cold) solve is not affected (``[hydro] cold_start``).
"""
from __future__ import annotations

import time as _time

import numpy as np


class CoarseCorrectedResolver:
    """A drop-in for the warm :class:`~breachflow.swe.solver.SWESolver` *full* (its options, tolerance,
    t_max, region and section are used): the whole-domain re-solve from the previous steady state plus the
    level change of a coarse grid *factor* times coarser (module docstring). ``last_info`` holds the CPU
    time (s) of the coarse and the fine part and the largest level change laid on the fine grid (m)."""

    def __init__(self, full, factor: int = 2):
        from .far_field import CoarseFarField

        self.full = full
        self.far = CoarseFarField(full, factor=factor)  # checks the factor
        self.factor = self.far.factor
        self._pile = None
        self.last = None
        self.last_info: dict = {}

    def __getattr__(self, name):  # options, tolerance, region, section... of the wrapped solver
        return getattr(self.__dict__["full"], name)

    def _box(self, dom) -> tuple[int, int, int, int]:
        """The rows and columns the coarse steady test watches: those of the fine solver's monitored region
        (the breach vicinity), the whole domain without one."""
        from ..swe.solver import _mask

        ny, nx = dom.shape
        if self.full.region is None:
            return 0, ny, 0, nx
        J, I = np.nonzero(_mask(self.full.region, dom))
        if J.size == 0:
            return 0, ny, 0, nx
        return int(J.min()), int(J.max()) + 1, int(I.min()), int(I.max()) + 1

    def solve(self, domain, obstacles=None, initial=None):
        from ..swe.solver import _mask
        from .resolve_region import _shifted

        if initial is None:  # a cold solve: nothing to correct
            out = self.full.solve(domain, obstacles=obstacles)
            self.last = self.full.last
            return out
        dom = domain if obstacles is None else domain.with_obstacles(_mask(obstacles, domain))
        pile = getattr(dom, "porous", None)
        c0 = _time.process_time()
        d_eta = self.far.level_change(dom, initial, self._pile, self._box(dom))
        start = initial if d_eta is None else _shifted(initial, d_eta)
        c1 = _time.process_time()
        out = self.full.solve(dom, initial=start)
        self.last = self.full.last
        self.far.accept(out)
        self._pile = pile
        self.last_info = {"coarse_cpu": c1 - c0, "fine_cpu": _time.process_time() - c1,
                          "fine_time": float(self.last.t) if self.last is not None else float("nan"),
                          "max_level_change": 0.0 if d_eta is None else float(np.max(np.abs(d_eta))),
                          **{f"coarse_{k}": v for k, v in getattr(self.far, "last_coarse", {}).items()}}
        out.attrs["hydro_resolve"] = (f"coarse x{self.factor}: level change up to "
                                      f"{self.last_info['max_level_change']:.3f} m, then "
                                      f"{self.last_info['fine_time']:.0f} s on the run's grid")
        return out
