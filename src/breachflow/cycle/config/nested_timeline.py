"""The closure in time on a nested finer grid (``[hydro] refine`` with ``[closure] method``).

A refined run solves the breach on a nested grid whose edges take their levels and flows from the coarse
steady state of the embedded shallow-water model. Under the timeline the flood-side and polder levels
change from cycle to cycle, so the coarse steady state does too: :class:`NestedTimelineSolver` re-solves
the coarse model at the timeline's levels whenever they have moved since the last coarse solve (a warm
start from the previous coarse state; a cold start from the polder's level the first time the polder holds
water, as a uniform grid does), takes the nested grid's edge conditions and cold-start state from it, and
then solves the nested grid. A run on the nested grid (e.g. the verdict check's finer grid)
therefore carries the same flood, polder and start time as the run on the coarse grid."""
from __future__ import annotations

from dataclasses import replace


class NestedTimelineSolver:
    """*nested* (:class:`~breachflow.hydro.nested.NestedSolver` built on the coarse steady state
    *regional*) whose regional field follows the timeline *coarse*
    (:class:`~breachflow.cycle.timeline.TimelineSolver` of the coarse model) on *coarse_domain*."""

    def __init__(self, nested, coarse, coarse_domain, regional, *, manning: float, site_level: float):
        self.nested, self.coarse, self.coarse_domain = nested, coarse, coarse_domain
        self.timeline = coarse.timeline
        self.manning = float(manning)
        self._regional = regional
        #: the (flood level, tailwater) the regional field was solved at; the first one has the site's level
        #: and a free-draining polder
        self._levels = (float(site_level), None)
        self.responds_to_pile = True
        self.mode = getattr(nested, "mode", "nested")
        #: coarse re-solves done for a change of the timeline's levels
        self.coarse_solves = 0

    def __getattr__(self, name):  # box, source, region, fallback_sampler... of the nested solver
        return getattr(self.__dict__["nested"], name)

    def levels(self) -> tuple:
        tl = self.timeline
        tail = tl.tailwater
        return float(tl.flood_level), None if tail is None else float(tail)

    def _follow(self) -> None:
        """Re-solve the coarse model when the timeline's levels differ from those of the regional field,
        and take the nested grid's boundaries and cold-start state from the new coarse state."""
        from ...hydro.nested import load_regional, nested_domain

        lv = self.levels()
        if lv == self._levels:
            return
        # once the polder holds water the coarse model starts over from its level (a cold start: the timeline
        # fills the polder's dry cells to it), as a uniform grid does; a warm start from the free-draining
        # field would spend its re-solve time filling the polder and hand on a transient
        cold = self._levels[1] is None and lv[1] is not None
        self._regional = self.coarse.solve(self.coarse_domain, initial=None if cold else self._regional)
        self.coarse_solves += 1
        self._levels = lv
        n = self.nested
        n.regional = load_regional(self._regional)
        n.__dict__.pop("_fallback", None)
        # the nested grid's own cell size: the breach's ends lie on its cell faces, so it is the refine
        # length only when that divides the breach length
        dom, init = nested_domain(n.regional, n.box, n.spacing, self.manning, leaving=n.leaving, frame=n.frame,
                                  terrain=n.terrain, flood_side=n.flood_side)
        n.initial_state = init
        from ...swe.domain import _copy_spacing

        d = replace(n.domain, boundaries=dom.boundaries)
        _copy_spacing(n.domain, d)
        n.domain = d

    def solve(self, domain=None, obstacles=None, initial=None):
        from ...swe.domain import _copy_spacing

        from ...hydro.nested import edge_on_flood_side
        from ..timeline import tailwater_relaxation, with_tailwater

        self._follow()
        domain = self.nested.domain if domain is None else domain
        # the edges of the coarse state; on the polder side, once it holds water, the polder's level (as on a
        # uniform grid under the timeline): not a free outflow that would let the gap flow run supercritical
        # into an empty polder, nor the coarse open breach's levels, which would drive water in and out of the
        # box's polder corners once the pile has shut the breach. With the flood side known, only the polder
        # side's stretches (hydro/nested.py)
        tail = self.timeline.tailwater
        fs = getattr(self.nested, "flood_side", None)
        protected = None if fs is None else (
            lambda side, bc, dom=self.nested.domain: not edge_on_flood_side(side, bc, dom, fs))
        d = replace(domain, boundaries=with_tailwater(self.nested.domain.boundaries, tail,
                                                      tailwater_relaxation(domain, tail), protected))
        _copy_spacing(domain, d)
        return self.nested.solve(d, obstacles=obstacles, initial=initial)
