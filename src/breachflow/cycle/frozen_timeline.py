"""The closure in time over an ingested flow model: a delivery method's clock with the flood held frozen.

An ingested model (``[hydro] solver = "nested"`` with ADH / HEC-RAS files, or ``"snapshot_frozen"``) takes
its flood-side and protected-side boundaries from the model's own result, so they cannot follow a flood
hydrograph or the polder's filling as the embedded model's do (:mod:`~breachflow.cycle.timeline`). With
``[closure] method`` such a run still gets the operation time of a real delivery: cycle ``g`` happens at

    t_g = start + calendar time of (tonnes placed up to cycle g) / capacity

(working hours and the wind limit of the method, :class:`~breachflow.cycle.delivery.DeliveryClock`), the
seal follows at its own delivery time, and the closure plan states the method, tonnage and duration.
The flood level stays at the site's (the ingested model's) level and the polder at its initial level
for the whole operation: the run says so in its plan and metadata, and the open breach's filling is not
simulated: the plan judges the finish against the report's linear closure window when the scenario gives one
(``[flood]``, ``[polder]``, ``[breach]``), and against none otherwise. The embedded flow model runs the same way with
``[closure] flood = "frozen"`` (a screening at a fixed flood level, timed by a real delivery).
"""
from __future__ import annotations

from dataclasses import dataclass

from .delivery import HOUR
from .timeline import FloodStage, Timeline


@dataclass
class FrozenFloodTimeline(Timeline):
    """A :class:`~breachflow.cycle.timeline.Timeline` whose flood and polder levels are held: the clock
    follows the delivered tonnes, nothing else moves. ``solver`` names the ingested flow model (None: the
    embedded one, held by ``[closure] flood = "frozen"``)."""

    solver: str | None = None
    #: the closure plan and the run's metadata say the flood is held frozen
    frozen: bool = True

    def begin(self) -> None:
        """The clock at the start of the closure; no breach growth or polder filling before it."""
        self.history, self.calibration = [], []
        self.balance_time = None
        self.time, self.polder_level, self.discharge = float(self.start), self.polder.initial_level, 0.0

    def calibrate(self, snapshot, solve, discharge_of):
        """Nothing to calibrate (no weir before the start): the open breach's discharge is recorded."""
        self.calibration = []
        self.discharge = float(discharge_of(snapshot))
        return snapshot

    def calibrate_window(self, solve, discharge_of):
        """Nothing to calibrate: the filling of the polder is not modelled (no window)."""
        self.window_coefficient, self.window_calibration = None, {}
        return None

    def _integrate(self, t_new: float, max_step: float = HOUR) -> None:
        self.time = max(float(t_new), self.time)  # the polder is held: only the clock moves

    def open_breach_window(self, inundation_depth: float | None = None, horizon: float = 0.0) -> float:
        return float("inf")  # the filling of the polder is not modelled: no window

    @property
    def note(self) -> str:
        why = ("[closure] flood = \"frozen\": the flow model's boundaries" if self.solver is None else
               f"the boundaries of the ingested flow model ([hydro] solver = {self.solver!r})")
        return (f"flood held frozen at {self.stage(0.0):.2f} m and polder at {self.polder.initial_level:.2f} m: "
                f"{why} do not follow the flood or the polder's filling; the operation time follows the delivered "
                f"tonnes only, and the only closure window is the report's linear one (when [flood], [polder] and "
                f"[breach] give it)")

    def describe(self) -> str:
        return (f"closure by {self.method.describe()}; start {self.start / HOUR:g} h after the breach; "
                f"{self.note}")


def frozen_flood(timeline: Timeline, level: float, solver: str | None = None) -> FrozenFloodTimeline:
    """*timeline* (built from the scenario: method, start, polder, wind, date) with the flood held at
    *level* (m) and no breach growth before the start: the closure in time of an ingested model (*solver*
    its name), or of the embedded one with ``[closure] flood = "frozen"`` (*solver* None)."""
    stage = FloodStage.constant(level)
    stage.source = f"held frozen at {float(level):.2f} m (" + (
        "[closure] flood = \"frozen\")" if solver is None else "the ingested flow model's boundaries)")
    return FrozenFloodTimeline(stage=stage, polder=timeline.polder, method=timeline.method, start=timeline.start,
                               bottom=timeline.bottom, length=timeline.length, wall_slope=timeline.wall_slope,
                               growth=None, wind=timeline.wind, breach_date=timeline.breach_date,
                               ground=timeline.ground, calibrate_weir=False, solver=solver)
