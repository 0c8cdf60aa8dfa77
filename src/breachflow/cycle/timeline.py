"""The closure in time: operation time, flood stage and polder level of each closure cycle.

Each cycle ``g`` happens at its operation time ``t_g`` (seconds since the breach)::

    t_g = calendar time after (tonnes delivered up to cycle g) / (method capacity) hours of work,
          counted from the start of the closure (working hours per day, calm wind; cycle/delivery.py)

The flood-side boundary of cycle ``g``'s flow solve is the flood stage at ``t_g`` (:class:`FloodStage`:
the site's constant level, its stage series, or the ``[flood]`` hydrograph: linear rates, a preset or a
measured CSV, as the closure window); the protected side is the polder's water level at ``t_g``
(:class:`~breachflow.scenario.polder.Polder`), integrated from the breach discharge minus the pumps:

    dV/dt = Q_breach - Q_pump,   V = A (z_P - z_0)  (or the polder's stage–storage curve)

Between two cycles the discharge is the one of the last steady solve (the pile as it stood); over
that interval the balance is exact in the volume (a piecewise-constant inflow). Before the start of
the closure the breach grows by the chosen growth law (``[breach] growth``, report eqs. 2.2–2.8, up
to the site's breach length) and discharges as a broad-crested weir (Fread's form,
:func:`~breachflow.scenario.discharge.weir_discharge`, submerged by the polder's tailwater) while the
polder fills; the first solve then starts from the polder level at the start time, and the weir's
coefficient is calibrated on that solve (:meth:`Timeline.calibrate`: the report's ideal weir passes more
than the flow model's breach, which contracts into the gap and loses head behind it).

The closure window of the breach left open (:meth:`Timeline.open_breach_window`) is a property of the breach
and the flood, not of the start: its weir is calibrated once, on the flow model's open breach at its full size
(the time the growth law reaches the breach length, the breach time without a growth law), whatever the start
(:meth:`Timeline.calibrate_window`). The weir's mismatch with the flow model changes with the polder's
tailwater, so a coefficient calibrated at each start would give each start a window of its own.

A polder that reaches the flood level has met the breach balance (report's ``t_Q``): the flow
through the breach stops, and the level stays with the flood's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..scenario.geometry import DEFAULT_WALL_SLOPE
from ..scenario.polder import Polder
from .delivery import DeliveryClock, DeliveryMethod, HOUR

#: relative tolerance of the weir's discharge against the flow model's at the start of the closure
CALIBRATION_TOLERANCE = 0.03
#: re-solves of the open breach allowed to calibrate the weir (each after re-integrating the pre-start phase)
CALIBRATION_SOLVES = 4

#: a protected-side boundary becomes a prescribed level (tailwater) once the polder water stands this
#: much above the protected-side ground; below it the polder edge drains freely (m)
TAILWATER_MIN_DEPTH = 0.05


@dataclass
class FloodStage:
    """Flood-side water level (m, datum of the bed) against time since the breach (s)."""

    level_at: object  #: callable t -> level
    source: str = "constant"

    def __call__(self, t) -> float:
        return float(self.level_at(float(t)))

    @classmethod
    def constant(cls, level: float) -> "FloodStage":
        return cls(lambda t, z=float(level): z, "the site's flood level (constant)")


def flood_stage_from_section(flood, ground: float) -> FloodStage:
    """The ``[flood]`` section's hydrograph as a level: ``ground`` + the stage above ground at
    ``breach_time + t`` (times of the hydrograph relative to the crest; the level does not fall below
    the ground)."""
    from ..scenario.config import _si_back  # noqa: F401  (the section holds SI values)
    from ..scenario.window import _linear_flood

    t0 = float(flood.breach_time or 0.0)
    if flood.hydrograph is not None:
        from ..scenario.hydrograph import MeasuredHydrograph

        hyd = MeasuredHydrograph.from_csv(flood.hydrograph, ground_elevation=flood.ground_elevation,
                                          column=flood.hydrograph_column)
        return FloodStage(lambda t: ground + max(float(hyd.stage(t0 + t)), 0.0),
                          f"measured hydrograph {flood.hydrograph.name}, breach {t0 / HOUR:g} h after the crest")
    vals = []
    for key in ("surge_height", "fall_rate", "rise_rate"):
        v = getattr(flood, key)
        if v is not None and np.ndim(np.asarray(getattr(v, "values", v))) != 0:
            raise InputError(f"[flood] {key}: a closure run takes one value, not a list")
        vals.append(None if v is None else f"{float(getattr(v, 'values', v))!r} {'m' if key == 'surge_height' else 'm/s'}")
    h, rr, rf = (float(v) for v in _linear_flood(vals[0], vals[1], vals[2], flood.preset))

    def level(t):
        tc = t0 + t
        return ground + max(h + rr * tc if tc < 0 else h - rf * tc, 0.0)

    what = f"preset {flood.preset}" if flood.preset else "linear hydrograph"
    return FloodStage(level, f"{what}: h_W {h:g} m, rise {rr * 3.6e5:.3g} cm/h, fall {rf * 3.6e5:.3g} cm/h, "
                             f"breach {t0 / HOUR:g} h after the crest")


@dataclass
class Timeline:
    """The clock, flood stage and polder balance of a closure run (SI; times since the breach).

    ``start`` the start of the closure; ``bottom`` the breach bottom and ``length`` / ``wall_slope`` the
    breach of the flow model (for the weir discharge before the start); ``growth`` a callable ``t ->
    B(t)`` (m) of the breach before it reached ``length`` (None: the full breach from the breach on);
    ``wind`` ``(times s since the breach, speeds m/s)``; ``breach_date`` the date-time of the breach
    (numpy datetime64) or None."""

    stage: FloodStage
    polder: Polder
    method: DeliveryMethod
    start: float = 0.0
    bottom: float = 0.0
    length: float = 0.0
    wall_slope: float = DEFAULT_WALL_SLOPE
    growth: object = None
    wind: tuple | None = None
    breach_date: object = None
    ground: float | None = None  #: protected-side ground (m): a tailwater above it is imposed
    #: weir coefficient C (m^0.5/s): the report's 3.1 ft^0.5/s (Fread 1996)
    weir_coefficient: float = 3.1 * 0.3048 ** 0.5
    #: a constant breach discharge before the start (m³/s; the report's linear model ``Q_D``, §2.4) instead
    #: of the weir: it flows until the polder meets the flood level
    prestart_discharge: float | None = None
    prestart_step: float = 600.0
    #: calibrate the weir's coefficient on the flow model's open breach at the start (:meth:`calibrate`)
    calibrate_weir: bool = True
    #: the weir's discharge at the start matches the flow model's within this relative tolerance after calibration
    calibration_tolerance: float = CALIBRATION_TOLERANCE
    #: at most this many re-solves of the open breach at the start while calibrating
    calibration_solves: int = CALIBRATION_SOLVES
    #: the calibration's steps: coefficient, weir and flow-model discharge and polder level at the start
    calibration: list = field(default_factory=list)
    #: the weir coefficient of the closure window (m^0.5/s), calibrated at the breach's full size
    #: (:meth:`calibrate_window`); None: the window uses ``weir_coefficient``
    window_coefficient: float | None = None
    #: the window calibration: reference time and state, its steps and the calibrated weir (:meth:`calibrate_window`)
    window_calibration: dict = field(default_factory=dict)
    # state
    time: float = 0.0
    polder_level: float = float("nan")
    discharge: float = 0.0
    balance_time: float | None = None
    delivered: float = 0.0  #: kg delivered so far
    history: list = field(default_factory=list)

    def __post_init__(self):
        if not (np.isfinite(self.start) and self.start >= 0):
            raise InputError(f"[closure] start must be >= 0 s after the breach, got {self.start!r}")
        self.clock = DeliveryClock(self.method, self.start, self.wind)
        self.polder_level = self.polder.initial_level
        if self.ground is None:
            self.ground = self.polder.initial_level

    # ------------------------------------------------------------------ levels
    @property
    def flood_level(self) -> float:
        return self.stage(self.time)

    @property
    def head(self) -> float:
        """Head across the breach (m): flood level − polder level (the polder counted from the breach bottom)."""
        return self.flood_level - max(self.polder_level, self.bottom)

    @property
    def tailwater(self) -> float | None:
        """The protected-side level to impose (m), or None while the polder is (nearly) dry."""
        z = self.polder_level
        return z if z > self.ground + TAILWATER_MIN_DEPTH else None

    @property
    def datetime(self):
        """Date-time of the current operation time (None when the breach is not dated)."""
        if self.breach_date is None:
            return None
        return self.breach_date + np.timedelta64(int(round(self.time)), "s")

    # ------------------------------------------------------------------ before the start
    def breach_length_at(self, t: float) -> float:
        if self.growth is None:
            return self.length
        return float(min(max(float(self.growth(t)), 0.0), self.length))

    def weir(self, t: float, polder_level: float) -> float:
        """Breach discharge (m³/s) before the start: broad-crested weir over the breach of length B(t),
        ``k_s C (b H^1.5 + (2.45/3.1) m H^2.5)`` (:func:`~breachflow.scenario.discharge.weir_discharge`,
        Fread's form, submerged by the polder's tailwater)."""
        from ..scenario.discharge import SIDE_TO_BOTTOM_COEFFICIENT, submergence_factor

        head = self.stage(t) - self.bottom
        if head <= 0:
            return 0.0
        tail = max(polder_level - self.bottom, 0.0)
        if tail >= head:
            return 0.0
        if self.prestart_discharge is not None:
            return float(self.prestart_discharge)
        b = self.breach_length_at(t)
        if b <= 0:
            return 0.0
        q = self.weir_coefficient * (b * head ** 1.5 + SIDE_TO_BOTTOM_COEFFICIENT * self.wall_slope * head ** 2.5)
        return float(q * (submergence_factor(head, tail) if tail > 0 else 1.0))

    def begin(self) -> None:
        """Integrate the polder from the breach to the start of the closure (weir discharge of the growing
        breach), leaving the clock at ``start``."""
        self.history = []
        self.balance_time = None
        z, q, t, bal = self._open_breach(self.start, log=True)
        self.polder_level, self.discharge, self.time, self.balance_time = z, q, self.start, bal

    def calibrate_from(self, coefficient: float | None) -> float | None:
        """Let the weir calibrations (:meth:`calibrate_window`, :meth:`calibrate`) begin from *coefficient*
        (m^0.5/s; the verdict check's finer grid: the coefficient the run calibrated on its own grid) instead of
        the report's. Returns the coefficient taken, or None when there is nothing to calibrate (a fixed
        pre-start discharge, ``calibrate_weir`` off: the weir's coefficient stays as given) or *coefficient* is
        None."""
        if coefficient is None or not self.calibrate_weir or self.prestart_discharge is not None:
            return None
        self.weir_coefficient = float(coefficient)
        return self.weir_coefficient

    def calibrate(self, snapshot, solve, discharge_of):
        """Calibrate the weir's coefficient on the flow model's open breach at the start of the closure.

        The report's weir (an ideal broad-crested weir, 3.1 ft^0.5/s) is not the flow model's breach: the
        flow contracts into the gap and loses head spreading into the polder, and the tailwater of the
        polder acts on the whole flow field, not only on a crest. After :meth:`begin`, *snapshot* is the
        flow model's steady open breach at the start (*discharge_of(snapshot)* its breach discharge, m³/s).
        The coefficient is scaled by the ratio of the two discharges, the pre-start phase is integrated
        again with it (the polder at the start changes with it), and the breach re-solved there
        (*solve(previous_snapshot)*, a warm start) until the weir at the start is within
        ``calibration_tolerance`` of the flow model (at most ``calibration_solves`` re-solves). Returns the
        last snapshot; the steps are in ``calibration``. Skipped with a fixed pre-start discharge or
        ``calibrate_weir`` off."""
        self.calibration = []
        if not self.calibrate_weir or self.prestart_discharge is not None:
            return snapshot
        q_model = float(discharge_of(snapshot))
        for k in range(self.calibration_solves + 1):
            q_weir = self.weir(self.start, self.polder_level)
            self.calibration.append({"weir_coefficient": float(self.weir_coefficient), "weir_discharge": float(q_weir),
                                     "model_discharge": q_model, "polder_level": float(self.polder_level),
                                     "flood_level": float(self.flood_level)})
            if not (q_weir > 0 and np.isfinite(q_model) and q_model > 0):
                break  # no flow to calibrate on (the balance reached, or a dry breach)
            if abs(q_model / q_weir - 1.0) <= self.calibration_tolerance or k == self.calibration_solves:
                break
            level = self.polder_level
            self.weir_coefficient *= q_model / q_weir
            self.begin()
            if self.polder_level != level:  # the start moved: the flow model's breach again there
                snapshot = solve(snapshot)
                q_model = float(discharge_of(snapshot))
        self.discharge = q_model
        return snapshot

    def full_size_time(self, horizon: float = 60 * 86400.0) -> float:
        """Time since the breach (s) at which the growth law reaches the breach length (0 without a growth
        law; *horizon* when it does not within it), to 1 s: the reference state of the window's weir."""
        if self.growth is None or self.breach_length_at(0.0) >= self.length:
            return 0.0
        lo, hi = 0.0, 60.0
        while self.breach_length_at(hi) < self.length:
            if hi >= horizon:
                return float(horizon)
            lo, hi = hi, min(2.0 * hi, horizon)
        while hi - lo > 1.0:  # bisection: B(lo) < length <= B(hi)
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.breach_length_at(mid) < self.length else (lo, mid)
        return float(hi)

    def calibrate_window(self, solve, discharge_of):
        """Calibrate the weir of the closure window on the flow model's open breach at its full size.

        The reference state does not depend on the start: the time ``t_r`` the growth law reaches the breach
        length (:meth:`full_size_time`; the breach time without a growth law), the flood level there and the
        polder level the weir integration gives there. Starting from the weir's coefficient as given (the
        report's), the breach is solved cold at that state (*solve()*, no warm start: the answer must not depend
        on what was solved before), the coefficient is scaled by the flow model's discharge over the weir's, the
        polder is integrated to ``t_r`` again with it, and the breach re-solved there when its level moved, until
        the two discharges agree within ``calibration_tolerance`` (at most ``calibration_solves`` re-solves; a
        reference at the breach time needs one solve: its polder does not depend on the coefficient). When the
        polder has met the flood before the breach reached its full size (no flow there), the full breach is
        solved with the polder at its initial level at ``t_r`` instead: one ratio, a state of the same breach. Sets
        ``window_coefficient`` and ``window_calibration``; the timeline's coefficient and state are left as they
        were (call after :meth:`begin`). Returns the snapshot of the first solve when it was the start's own
        state (the start is the reference time: the caller need not solve it again), else None. Skipped (None)
        with a fixed pre-start discharge or ``calibrate_weir`` off: the window then uses ``weir_coefficient``."""
        self.window_coefficient, self.window_calibration = None, {}
        if not self.calibrate_weir or self.prestart_discharge is not None:
            return None
        saved = (self.time, self.polder_level, self.discharge, list(self.history), self.balance_time,
                 self.weir_coefficient)
        t_ref = self.full_size_time()
        first = None
        steps = []
        try:
            self._open_breach(t_ref)
            snapshot = solve()
            if t_ref == self.start:
                first = snapshot
            q_model = float(discharge_of(snapshot))
            for k in range(self.calibration_solves + 1):
                q_weir = self.weir(t_ref, self.polder_level)
                steps.append({"weir_coefficient": float(self.weir_coefficient), "weir_discharge": float(q_weir),
                              "model_discharge": q_model, "polder_level": float(self.polder_level),
                              "flood_level": float(self.stage(t_ref))})
                if not (q_weir > 0 and np.isfinite(q_model) and q_model > 0):
                    break  # no flow at the reference (the balance reached before it, or a dry breach)
                if abs(q_model / q_weir - 1.0) <= self.calibration_tolerance or k == self.calibration_solves:
                    break
                level = self.polder_level
                self.weir_coefficient *= q_model / q_weir
                self._open_breach(t_ref)
                if self.polder_level != level:
                    snapshot = solve()
                    q_model = float(discharge_of(snapshot))
            reference = "the polder level of the weir integration"
            if not (steps[-1]["weir_discharge"] > 0 and q_model > 0) and self.polder_level > self.polder.initial_level:
                # the polder met the flood before the breach reached its full size: the full breach against the
                # polder at its initial level instead, at the same time (a state of the same breach in both)
                reference = "the polder at its initial level (the balance came before the full size)"
                self.weir_coefficient, self.polder_level = saved[5], self.polder.initial_level
                snapshot = solve()
                if t_ref == self.start:
                    first = None  # not the start's state
                q_model = float(discharge_of(snapshot))
                q_weir = self.weir(t_ref, self.polder_level)
                steps.append({"weir_coefficient": float(self.weir_coefficient), "weir_discharge": float(q_weir),
                              "model_discharge": q_model, "polder_level": float(self.polder_level),
                              "flood_level": float(self.stage(t_ref))})
                if q_weir > 0 and np.isfinite(q_model) and q_model > 0:
                    self.weir_coefficient *= q_model / q_weir
            self.window_coefficient = float(self.weir_coefficient)
            self.window_calibration = {
                "time_s": float(t_ref), "polder": reference, "breach_length_m": float(self.breach_length_at(t_ref)),
                "flood_level_m": float(self.stage(t_ref)), "polder_level_m": float(self.polder_level),
                "weir_coefficient": self.window_coefficient, "model_discharge_m3_s": q_model,
                "weir_discharge_m3_s": float(self.weir(t_ref, self.polder_level)),
                "flowing": bool(steps and steps[-1]["weir_discharge"] > 0 and q_model > 0), "steps": steps}
        finally:
            (self.time, self.polder_level, self.discharge, self.history, self.balance_time,
             self.weir_coefficient) = saved
        return first

    def _open_breach(self, t_end: float, *, log: bool = False, inundation: float | None = None):
        """The open breach from the breach to *t_end* (or to the balance / the polder *inundation* depth
        above its initial level, whichever first when *inundation* is given): returns ``(polder level,
        discharge, time reached, balance time or None)``."""
        z = self.polder.initial_level
        self.time, self.polder_level = 0.0, z
        q = self.weir(0.0, z)
        if log:
            self._log("growth", q)
        t0, bal = 0.0, None
        while t0 < t_end - 1e-9:
            # steps of at most prestart_step, and short enough that the polder rises by at most 2 % of the head
            head = max(self.stage(t0) - max(z, self.bottom), 0.01)
            fill = 0.02 * head * self.polder.plan_area(z) / max(q, 1e-9)
            t1 = min(t_end, t0 + max(min(self.prestart_step, fill), 1.0))
            # midpoint discharge (second order): the weir at the half-step level
            zh, half_cross = self.polder.step(z, 0.5 * (t1 - t0), q, (self.stage(t0), self.stage(0.5 * (t0 + t1))))
            qm = self.weir(0.5 * (t0 + t1), zh) if half_cross is None else q  # balance within the half step
            z1, cross = self.polder.step(z, t1 - t0, qm, (self.stage(t0), self.stage(t1)))
            if cross is not None and bal is None:
                bal = t0 + cross
            if inundation is not None and (bal is not None or z1 - self.polder.initial_level >= inundation):
                if bal is None:  # the time the polder reached the depth, within the step (linear)
                    frac = (self.polder.initial_level + inundation - z) / max(z1 - z, 1e-12)
                    return z1, qm, t0 + frac * (t1 - t0), None
                return z1, qm, bal, bal
            z, t0 = z1, t1
            q = self.weir(t1, z1)
            self.time, self.polder_level = t1, z1
            if log and (len(self.history) < 2 or t1 - self.history[-1]["time"] >= self.prestart_step or t1 >= t_end):
                self._log("growth", q)
            if inundation is not None and q <= self.polder.pump_capacity and self.stage(t1) <= self.stage(t0):
                return z, q, float("inf"), None  # the pumps keep up with a falling flood: no window end
        return z, q, t0, bal

    def open_breach_window(self, inundation_depth: float | None = None, horizon: float = 60 * 86400.0):
        """The closure window of the breach left open (s since the breach): the first of the breach balance
        and the polder reaching *inundation_depth* (m above its initial level), with the weir discharge of
        the growing breach as before the start; inf when neither happens within *horizon*. The weir's
        coefficient is ``window_coefficient`` (calibrated at the breach's full size, :meth:`calibrate_window`:
        the same window for every start), else ``weir_coefficient``. The timeline's state is left as it was."""
        saved = (self.time, self.polder_level, self.discharge, list(self.history), self.balance_time,
                 self.weir_coefficient)
        try:
            if self.window_coefficient is not None:
                self.weir_coefficient = self.window_coefficient
            _, _, t, _ = self._open_breach(horizon, inundation=inundation_depth if inundation_depth else 1e9)
        finally:
            (self.time, self.polder_level, self.discharge, self.history, self.balance_time,
             self.weir_coefficient) = saved
        return float(t) if t < horizon else float("inf")

    # ------------------------------------------------------------------ during the closure
    def advance(self, delivered: float) -> float:
        """Move the clock to the operation time after *delivered* kg in all (the masses placed so far) and
        integrate the polder with the last discharge over the interval; returns the new time (s)."""
        self.delivered = float(delivered)
        t_new = self.clock.time_after(self.method.work_time(self.delivered))
        self._integrate(t_new)
        return self.time

    def _integrate(self, t_new: float, max_step: float = HOUR) -> None:
        t = self.time
        while t < t_new - 1e-9:
            t1 = min(t + max_step, t_new)
            z1, cross = self.polder.step(self.polder_level, t1 - t, self.discharge, (self.stage(t), self.stage(t1)))
            if cross is not None and self.balance_time is None:
                self.balance_time = t + cross
            self.polder_level, t = z1, t1
        self.time = max(t_new, self.time)

    def record(self, discharge: float, phase: str = "closure") -> None:
        """The breach discharge (m³/s) of the solve at the current time (the flow until the next cycle)."""
        self.discharge = float(discharge) if np.isfinite(discharge) else 0.0
        self._log(phase, self.discharge)

    def _log(self, phase, q):
        self.history.append({"phase": phase, "time": float(self.time), "flood_level": self.flood_level,
                             "polder_level": float(self.polder_level), "breach_discharge": float(q),
                             "delivered_t": self.delivered / 1000.0})

    # ------------------------------------------------------------------ resume
    def state(self) -> dict:
        """What a cycle summary stores to restore the timeline on resume."""
        return {"operation_time": float(self.time), "flood_level": float(self.flood_level),
                "polder_level": float(self.polder_level), "timeline_discharge": float(self.discharge),
                "delivered_t": self.delivered / 1000.0,
                "balance_time": None if self.balance_time is None else float(self.balance_time),
                "weir_coefficient": float(self.weir_coefficient),
                "window_coefficient": None if self.window_coefficient is None else float(self.window_coefficient)}

    def restore(self, summary: dict) -> None:
        self.time = float(summary["operation_time"])
        self.polder_level = float(summary["polder_level"])
        self.discharge = float(summary.get("timeline_discharge", summary.get("breach_discharge", 0.0)))
        self.delivered = 1000.0 * float(summary.get("delivered_t", 0.0))
        bt = summary.get("balance_time")
        self.balance_time = None if bt is None else float(bt)
        if "weir_coefficient" in summary:  # as calibrated at the start
            self.weir_coefficient = float(summary["weir_coefficient"])
        if summary.get("window_coefficient") is not None:  # as calibrated at the breach's full size
            self.window_coefficient = float(summary["window_coefficient"])

    def describe(self) -> str:
        return (f"closure by {self.method.describe()}; start {self.start / HOUR:g} h after the breach; flood: "
                f"{self.stage.source}; polder {self.polder.area / 1e4:,.0f} ha, pumps {self.polder.pump_capacity:g} m³/s")


def tailwater_relaxation(domain, tail: float | None) -> float | None:
    """Relaxation time (s) of the absorbing polder level: ``4 L / sqrt(g h)``, the quarter-wave period of the
    domain's span ``L`` across the levee (m) at the depth ``h`` of the polder water over the lowest bed, as the
    flood side's (:func:`~breachflow.swe.domain.breach_domain`). None while the polder is dry (*tail* None)."""
    if tail is None:
        return None
    y = np.asarray(domain.y, float)
    span = max(float(y.max() - y.min()), 1.0)
    depth = max(float(tail) - float(np.nanmin(domain.bed)), 1e-3)
    return 4.0 * span / math.sqrt(9.81 * depth)


def with_tailwater(boundaries: dict, tail: float | None, relaxation: float | None = None, protected=None) -> dict:
    """*boundaries* with every free-outflow edge turned into the prescribed polder level *tail* (m); unchanged
    while the polder is (nearly) dry (*tail* None). The protected side of a flow model then stands at the
    polder's level, as the polder balance has it, instead of draining freely. The level is absorbing with
    *relaxation* (s; :func:`tailwater_relaxation`): an exactly imposed level reflects every wave, and the basin
    between it, the levee and the side walls would ring for hours (:class:`~breachflow.swe.domain.BoundaryCondition`).

    *protected* ``(side, bc) -> bool``: the stretches on the polder side; then exactly those (every kind but
    walls) take the polder's level, and a free outflow elsewhere stays free. A nested grid's edges come from a
    coarse field solved without the pile: on the polder side they would hold the open breach's levels (where its
    jet leaves, where eddies come back in) against a pile that has shut it."""
    from ..swe.domain import BoundaryCondition

    if tail is None:
        return boundaries

    def polder(side, bc):
        return bc.kind == "outflow" if protected is None else (bc.kind != "wall" and protected(side, bc))

    return {side: [BoundaryCondition.water_level(tail, start=bc.start, stop=bc.stop, absorbing=relaxation)
                   if polder(side, bc) else bc for bc in lst] for side, lst in boundaries.items()}


class TimelineSolver:
    """A flow solver whose boundaries follow the timeline: before each solve, the flood-side level is the
    flood stage at the current operation time and the protected side the polder level (a prescribed
    level once the polder water stands above its ground; free drainage before). *boundaries_at* is a
    callable ``flood_level -> boundaries dict`` of the site (flood-side level sources, the rest free
    outflow)."""

    def __init__(self, inner, timeline: Timeline, boundaries_at):
        self.inner, self.timeline, self.boundaries_at = inner, timeline, boundaries_at
        self.responds_to_pile = getattr(inner, "responds_to_pile", True)

    def __getattr__(self, name):  # box, last, last_info... of the wrapped solver
        return getattr(self.__dict__["inner"], name)

    def boundaries(self, domain):
        tl = self.timeline
        tail = tl.tailwater
        return with_tailwater(self.boundaries_at(tl.flood_level), tail, tailwater_relaxation(domain, tail))

    def solve(self, domain, obstacles=None, initial=None):
        from dataclasses import replace

        from ..swe.domain import _copy_spacing

        d = replace(domain, boundaries=self.boundaries(domain))
        tail = self.timeline.tailwater
        if initial is None and tail is not None and domain.initial_surface is not None:
            # a cold start with the polder already filled: its dry cells start at the polder level, not empty
            # (filling them from the polder edges would be a long transient of no interest)
            init = np.asarray(domain.initial_surface, float)
            dry = ~(init > domain.bed)
            d.initial_surface = np.where(dry & (domain.bed < tail) & ~np.asarray(domain.obstacle, bool), tail, init)
        _copy_spacing(domain, d)
        return self.inner.solve(d, obstacles=obstacles, initial=initial)


def cycle_variables(rep, timeline: Timeline | None) -> dict:
    """The per-cycle CF variables of a cycle file (0-d here; the ``cycle`` dimension is added with the
    others): ``flood_level``, ``polder_level`` (m, datum of the bed), ``operation_time`` (since the breach;
    CF time units ``seconds since <breach_date>`` when the breach is dated) and ``breach_discharge``."""
    import xarray as xr

    dated = timeline is not None and timeline.breach_date is not None
    t_units = f"seconds since {np.datetime_as_string(timeline.breach_date, unit='s').replace('T', ' ')}" if dated else "s"
    t_attrs = {"units": t_units, "long_name": "operation time of the cycle since the breach",
               "calendar": "proleptic_gregorian"} if dated else {
        "units": "s", "long_name": "operation time of the cycle since the breach"}
    polder_attrs = {"units": "m", "long_name": "polder water level (protected side) at the cycle's solve",
                    "comment": "elevation in the datum of bed_elevation"}
    if timeline is None:
        polder_attrs["comment"] += "; NaN: no polder balance ([closure] method not set)"
    return {
        "flood_level": xr.DataArray(float(rep.flood_level), attrs={
            "units": "m", "long_name": "flood-side water level at the cycle's solve",
            "comment": "elevation in the datum of bed_elevation"}),
        "polder_level": xr.DataArray(float(rep.polder_level), attrs=polder_attrs),
        "operation_time": xr.DataArray(float(rep.operation_time), attrs=t_attrs),
        "breach_discharge": xr.DataArray(float(rep.breach_discharge), attrs={
            "units": "m3 s-1", "long_name": "discharge through the breach section after the cycle's re-solve "
                                            "(overflow and seepage through the pile)"}),
    }
