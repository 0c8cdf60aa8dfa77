"""The seal in the flow model: finer layers on the upstream face of the porous pile, re-solved until the
leakage meets the ``polder_leakage`` criterion.

When the rock dam holds (the closure criteria are met with a seal, :mod:`breachflow.cycle.leakage`), the
seal and its filters (``[criteria] polder_leakage = { seal = [...] }``, finest first) are laid on the
flood-side face of the pile *in the shallow-water model's pile cells*: in every grid column through the
pile, the layers start at the upstream edge of the first pile cell and follow each other downstream, each
over its thickness (m, measured along the flow). A cell holding the lengths ``l_k`` of layers ``k`` (and
the rest ``l_r = Δy - Σ l_k`` of rock) gets the Forchheimer coefficients of the layers in series,

    ``A = (l_r A_rock + Σ l_k A_k) / Δy``,  ``B = (l_r B_rock + Σ l_k B_k) / Δy``,

exact for flow normal to the layers, since the superficial velocity is the same in every layer of a cell
and the head losses add. The layers cover the pile's height in the cell up to the flood level (the wetted
face). The flow is re-solved with the run's solver, warm-started from the last cycle and solved on to its
steady state (up to the criterion's ``steady_cap``, as at the rock stage's end, :mod:`breachflow.cycle.rock_end`;
a leakage read from a re-solve still not steady then does not seal the dam), and the leakage read
from the re-solve; while the criterion is not met the seal is thickened (by the leakage over the target, at
least by the factor ``seal_growth``, default 1.25, a step), up to ``max_seal_thickness`` or the seal material available (``seal_available``).

How the leakage is read (``seal_leakage``):

* ``"series"`` (default): the upstream face cells of the columns where the pile stands above the flood
  level are closed in the re-solve, which gives the overflow and the flow around the dam and the water
  levels on both sides with the dam sealed; the seepage through each sealed column is the 1-D flow through
  the layers in series under the head between the open cells before and after the pile
  (:func:`series_leakage`). Leakage = re-solved breach discharge + that seepage. When the closed faces cut
  every path of the flood's water to the polder (:func:`separates`), the re-solve's steady state is known:
  water at rest at the flood level before the dam and the polder level behind it (:func:`still_water`), and
  the leakage is read from it without a re-solve.
* ``"flow_model"``: the breach discharge of the re-solve with the seal in the pile cells. The depth-averaged
  solver's numerical flux across a steep drop of the water level adds flow that the seal's resistance
  does not stop: through a strip sealed with 5 cm gravel it over-states the 1-D flow by 16 %, 8 % and 4 %
  on 0.5, 0.25 and 0.125 m cells, and through 1 m of sand (0.3 mm) by a factor 72 on 0.25 m and 108 on 1 m
  cells (``tests/cycle/test_sealing.py`` and the documentation page *Materials and the seal*). A seal of
  sand or fine gravel is much thinner than the cells of a breach model, so this reading suits coarse
  filter layers or fine grids only.

Tonnage of a layer: its bulk volume in the pile cells (length × Δx × wetted height) × ``(1 - n) rho_s``.
Delivery: the seal's own method (``seal_method``, a delivery method's name; default the run's
``[closure] method``; ``seal_capacity`` overrides its capacity) delivers the layers after the rock, within
its working hours (:class:`~breachflow.cycle.delivery.DeliveryClock`); the polder is integrated over that
time with the rock dam's leakage (an upper bound: the leakage falls as the seal goes in). The re-solves
use the flood and polder levels at the end of the rock stage.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

HOUR = 3600.0


def flood_side(snapshot, breach_x, levee_y) -> int:
    """-1 when the flood is on the low-y side of the levee (flow towards +y through the breach), +1 otherwise."""
    x = np.asarray(snapshot["x"].values, float)
    y = np.asarray(snapshot["y"].values, float)
    j = int(np.argmin(np.abs(y - levee_y)))
    sel = (x >= breach_x[0]) & (x <= breach_x[1])
    q = float(np.sum(np.asarray(snapshot["depth"].values, float)[j, sel] * np.asarray(snapshot["v"].values, float)[j, sel]))
    return -1 if q >= 0.0 else 1


def seal_pile(pile, y, layers, side: int = -1, x=None, x_range=None, dx: float | None = None,
              law: str | None = None, height_cap=None):
    """The pile *pile* (:class:`~breachflow.swe.porous.PorousPile`, arrays ``(ny, nx)`` on the cell centres
    *y*) with the seal *layers* ``[(Grading, thickness m), ...]`` (from the water downstream) on its upstream
    face; *side* -1 when the flood is at low y. *x_range* (with *x*) limits the sealed columns.

    Returns ``(sealed_pile, tonnage)``: a new PorousPile with the series coefficients in the sealed cells and
    the tonnes (t) of each layer (by grading name) in them; *height_cap* (m, per cell or scalar) limits the
    sealed height (e.g. the water depth: the wetted face)."""
    from ..swe.porous import PorousPile

    y = np.asarray(y, float)
    ny, nx = pile.height.shape
    dy = abs(y[1] - y[0]) if y.size > 1 else 1.0
    if dx is None:
        dx = abs(x[1] - x[0]) if x is not None and len(x) > 1 else dy
    cols = np.arange(nx)
    if x_range is not None and x is not None:
        xx = np.asarray(x, float)
        cols = cols[(xx >= x_range[0] - 0.5 * dx) & (xx <= x_range[1] + 0.5 * dx)]
    coef = [(g, float(t), *g.forchheimer(law)) for g, t in layers]
    if any(not t > 0 for _, t, _, _ in coef):
        raise InputError(f"seal: every layer needs a thickness > 0 m, got {[t for _, t, _, _ in coef]}")
    edges = np.concatenate([[0.0], np.cumsum([t for _, t, _, _ in coef])])
    A, B = pile.A.copy(), pile.B.copy()
    LA, LB = pile.layer_A.copy(), pile.layer_B.copy()
    hgt = np.asarray(pile.height, float)
    cap = hgt if height_cap is None else np.minimum(hgt, np.broadcast_to(np.asarray(height_cap, float), hgt.shape))
    tons = {g.name: 0.0 for g, *_ in coef}
    for i in cols:
        jj = np.flatnonzero(hgt[:, i] > 0)
        if jj.size == 0:
            continue
        if side < 0:
            face = y[jj.min()] - 0.5 * dy
            lo, hi = y[jj] - 0.5 * dy - face, y[jj] + 0.5 * dy - face
        else:
            face = y[jj.max()] + 0.5 * dy
            lo, hi = face - y[jj] - 0.5 * dy, face - y[jj] + 0.5 * dy
        rest = np.full(jj.size, dy)
        a_sum = np.zeros(jj.size)
        b_sum = np.zeros(jj.size)
        for k, (g, _t, a_k, b_k) in enumerate(coef):
            ov = np.clip(np.minimum(hi, edges[k + 1]) - np.maximum(lo, edges[k]), 0.0, None)
            rest -= ov
            a_sum += ov * a_k
            b_sum += ov * b_k
            tons[g.name] += float(np.sum(ov * dx * np.maximum(cap[jj, i], 0.0))) * (1 - g.porosity) * g.density / 1e3
        rest = np.clip(rest, 0.0, None)
        A[jj, i] = (rest * pile.A[jj, i] + a_sum) / dy
        B[jj, i] = (rest * pile.B[jj, i] + b_sum) / dy
        # every layer of the column (swe/porous.py) in series with the seal over the same stretch
        LA[jj, i] = (rest[:, None] * pile.layer_A[jj, i] + a_sum[:, None]) / dy
        LB[jj, i] = (rest[:, None] * pile.layer_B[jj, i] + b_sum[:, None]) / dy
    sealed = PorousPile(height=pile.height, porosity=pile.porosity, diameter=pile.diameter, A=A, B=B,
                        law=pile.law, layer_porosity=pile.layer_porosity, layer_A=LA, layer_B=LB)
    return sealed, tons


def face_cells(pile, side, x_range, x, level, bed, obstacle=None) -> np.ndarray:
    """Mask of the pile cells that touch the open water on the flood side (4-neighbours of the open cells
    connected to the flood-side edge without passing through the pile), in columns within *x_range*
    whose pile stands at or above *level* (emergent: no overflow there). Closing them seals the dam's
    whole upstream envelope, the steps between columns included."""
    from scipy import ndimage

    pile_m = pile.height > 0
    open_m = ~pile_m if obstacle is None else ~pile_m & ~np.asarray(obstacle, bool)
    touch = pile_m & ndimage.binary_dilation(flood_connected(open_m, side))
    cols = (np.asarray(x) >= x_range[0]) & (np.asarray(x) <= x_range[1])
    crest = np.max(np.where(pile_m, bed + pile.height, -np.inf), axis=0)
    return touch & (cols & (crest >= level))[None, :]


def flood_connected(passable, side: int) -> np.ndarray:
    """Mask of the *passable* cells the flood side's water reaches: 4-connected (the flow model's faces) to the
    flood-side edge row (row 0 when *side* is -1, the last row otherwise)."""
    from scipy import ndimage

    lab, _ = ndimage.label(np.asarray(passable, bool))
    edge = lab[0] if side < 0 else lab[-1]
    return np.isin(lab, np.unique(edge[edge > 0]))


def separates(pile, reach, side: int) -> bool:
    """Whether the flood's water *reach* (:func:`flood_connected` over the cells below the flood level, with
    the levee, the pile's emergent cells and the sealed faces as barriers) stops at the dam: no reached cell
    lies beyond the pile's downstream row."""
    rows = np.flatnonzero((np.asarray(pile.height) > 0).any(axis=1))
    if rows.size == 0:
        return False
    beyond = reach[rows.max() + 1:] if side < 0 else reach[:rows.min()]
    return not bool(beyond.any())


def still_water(snapshot, bed, reach, flood_level: float, tailwater: float | None):
    """The steady state of the flow model behind a seal that :func:`separates` the two sides: water at rest at
    the *flood_level* in every cell the flood's water *reach*-es, at the polder's *tailwater* (m; None while the
    polder is dry) elsewhere, dry where the bed stands higher. A grid snapshot on the grid of *snapshot* (its
    obstacles, CRS and attributes kept, the derived fields of water at rest), marked steady: it is the model's
    exact steady state, reached without a re-solve."""
    from ..field.derived import derived_fields
    from ..field.snapshot import grid_snapshot

    bed = np.asarray(bed, float)
    low = bed if tailwater is None else np.maximum(bed, tailwater)
    depth = np.maximum(np.where(reach, flood_level, low) - bed, 0.0)
    zero = np.zeros_like(depth)
    manning = np.asarray(snapshot["manning_n"].values, float) if "manning_n" in snapshot else np.full_like(depth, 0.03)
    extra = {k: (("y", "x"), a, attrs) for k, (a, attrs) in derived_fields(bed, depth, zero, zero, manning).items()}
    obstacle = np.asarray(snapshot["obstacle"].values) if "obstacle" in snapshot else None
    out = grid_snapshot(snapshot["x"].values, snapshot["y"].values, bed, depth, zero, zero, obstacle=obstacle,
                        source="breachflow: water at rest behind a sealed dam", extra=extra)
    if "crs" in snapshot:
        out["crs"] = snapshot["crs"]
    out.attrs.update({k: v for k, v in snapshot.attrs.items() if k not in out.attrs})
    out.attrs.update(steady_state=1, simulated_time_s=0.0, seal_reading="still water")
    return out


def series_leakage(snapshot, pile, layers, side, x_range, law=None, columns=None) -> float:
    """Seepage (m³/s) through the sealed pile by the 1-D model of layers in series
    (:func:`~breachflow.materials.seal.series_unit_discharge`) column by column, with the head and the
    saturated height read from the re-solved field *snapshot*: the water level of the open cell just
    upstream of the pile minus that just downstream; height the upstream depth; the rock's length the pile's
    length in the column less the layers, its coefficients the column's mean. A check of the flow model's
    leakage, which over-states the flow through a thin layer of high resistance (module docstring)."""
    from ..materials.seal import series_unit_discharge

    x = np.asarray(snapshot["x"].values, float)
    y = np.asarray(snapshot["y"].values, float)
    dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
    dy = abs(y[1] - y[0]) if y.size > 1 else 1.0
    eta = np.asarray(snapshot["water_surface"].values, float)
    depth = np.asarray(snapshot["depth"].values, float)
    coef = [(float(t), *g.forchheimer(law)) for g, t in layers]
    total = 0.0
    for i in np.flatnonzero((x >= x_range[0]) & (x <= x_range[1])):
        jj = np.flatnonzero(pile.height[:, i] > 0)
        if jj.size == 0 or (columns is not None and not columns[i]):
            continue
        ju, jd = (jj.min() - 1, jj.max() + 1) if side < 0 else (jj.max() + 1, jj.min() - 1)
        if not (0 <= ju < y.size and 0 <= jd < y.size) or depth[ju, i] <= 0:
            continue
        head = float(eta[ju, i] - (eta[jd, i] if depth[jd, i] > 0 else eta[ju, i] - depth[ju, i]))
        rest = jj.size * dy - sum(c[0] for c in coef)
        lay = list(coef) + ([(rest, float(np.mean(pile.A[jj, i])), float(np.mean(pile.B[jj, i])))] if rest > 0 else [])
        total += series_unit_discharge(head, float(depth[ju, i]), lay) * dx
    return total


@dataclass
class SealStep:
    """One re-solve with the seal: its thickness (m), tonnes per layer, breach discharge after the re-solve
    (m³/s) and the polder verdict (:class:`~breachflow.cycle.leakage.LeakageVerdict`)."""

    thickness: float
    tonnage: dict
    leakage: float
    net_rise_per_day: float
    acceptable: bool
    solve_cpu_s: float = 0.0
    flow_model_leakage: float = float("nan")
    series_seepage: float = float("nan")
    #: whether the re-solve reached its steady state (:func:`~breachflow.cycle.rock_end.is_steady`); a leakage
    #: read from an unsteady re-solve does not seal the dam
    steady: bool = True
    #: how the levels on both sides were found: "re-solved" (the flow model) or "still water"
    #: (:func:`still_water`, the seal separates the sides)
    reading: str = "re-solved"

    def as_dict(self) -> dict:
        return {"seal_thickness_m": self.thickness, "tonnage_t": dict(self.tonnage),
                "seal_tonnage_t": float(sum(self.tonnage.values())), "leakage_m3_s": self.leakage,
                "net_rise_m_per_day": self.net_rise_per_day, "acceptable": self.acceptable,
                "solve_cpu_s": self.solve_cpu_s, "flow_model_leakage_m3_s": self.flow_model_leakage,
                "series_seepage_m3_s": self.series_seepage, "steady": self.steady,
                "reading": self.reading}


@dataclass
class SealResult:
    """The seal stage: its steps, whether the last meets the criterion, the delivery (method, t/h, the
    working seconds and the calendar times from and to), and the sealed snapshot."""

    steps: list = field(default_factory=list)
    sealed: bool = False
    verdict: str = ""
    method: str = ""
    capacity_t_h: float = float("nan")
    start_s: float = float("nan")
    finish_s: float = float("nan")
    work_s: float = 0.0
    snapshot: object = None
    flow_model_leakage: float | None = None  #: the flow model's leakage with the seal in its pile (a comparison)

    @property
    def last(self) -> SealStep | None:
        return self.steps[-1] if self.steps else None

    def as_dict(self) -> dict:
        last = self.last
        return {"sealed": self.sealed, "verdict": self.verdict, "method": self.method,
                "capacity_t_h": self.capacity_t_h, "start_s": self.start_s, "finish_s": self.finish_s,
                "work_s": self.work_s, "steps": [s.as_dict() for s in self.steps],
                "seal_thickness_m": last.thickness if last else None,
                "tonnage_t": dict(last.tonnage) if last else {},
                "seal_tonnage_t": float(sum(last.tonnage.values())) if last else 0.0,
                "leakage_m3_s": last.leakage if last else None,
                "net_rise_m_per_day": last.net_rise_per_day if last else None,
                "flow_model_leakage_m3_s": self.flow_model_leakage}


def seal_delivery(tonnes: float, method, start: float, wind=None) -> tuple[float, float]:
    """``(working seconds, calendar finish s since the breach)`` of delivering *tonnes* (t) by *method*
    (:class:`~breachflow.cycle.delivery.DeliveryMethod`) from *start*: ``tonnes / capacity`` of work, spread
    over the method's working hours (:class:`~breachflow.cycle.delivery.DeliveryClock`)."""
    from .delivery import DeliveryClock

    work = method.work_time(1000.0 * float(tonnes))
    return work, DeliveryClock(method, float(start), wind).time_after(work)


def next_thickness(t: float, leakage: float, target: float, t_max: float, growth: float) -> float:
    """The seal's next thickness (m) after a re-solve with *t* m let *leakage* (m³/s) through against the
    *target* (m³/s): the seal's share of the resistance grows with its thickness, so scale by 1.1 x the leakage
    over the target, at least by *growth* (``seal_growth``) and at most by 8, up to *t_max*."""
    ratio = abs(leakage) / target if target > 0 else 4.0
    return min(t_max, t * max(growth, min(ratio * 1.1, 8.0)))


def seal_dam(solve, pile, snapshot, criterion, *, breach_x, levee_y, y, x, thickness0: float | None = None,
             max_steps: int = 6, available_t: float | None = None, height_cap=None, flood_level=None, bed=None,
             compare_flow_model: bool = False, obstacle=None, tailwater: float | None = None,
             flow_sign: float = 1.0):
    """Place the seal of *criterion* (:class:`~breachflow.cycle.leakage.PolderLeakage` with ``seal_layers``)
    in *pile*, re-solve with ``solve(porous_pile, initial_snapshot, extra_obstacles) -> snapshot`` and thicken until the
    polder takes the leakage, the thickness reaches ``max_seal_thickness`` or the tonnage *available_t*.
    With the ``series`` reading, a seal that :func:`separates` the flood side from the polder needs no re-solve:
    the model's steady state is then water at rest (:func:`still_water`: the *flood_level* before the dam, the
    polder's *tailwater* behind it) and the leakage the series seepage under that head.
    Returns a :class:`SealResult` (delivery fields left for the caller). The leakage counts from the flood
    side into the polder (*flow_sign*: :func:`~breachflow.swe.section.flow_sign`)."""
    import time as _time

    from .criteria import section_discharge
    from .leakage import SEAL_GROWTH, SECONDS_PER_DAY, polder_leakage_check
    from .rock_end import is_steady

    if not criterion.seal_layers:
        raise InputError("seal: the polder_leakage criterion has no seal layers ([criteria] polder_leakage.seal)")
    side = flood_side(snapshot, breach_x, levee_y)
    t_max = criterion.max_seal_thickness
    t = min(t_max, max(thickness0 if thickness0 and math.isfinite(thickness0) else 0.25 * t_max, 0.05))
    pump = criterion.pump_capacity or 0.0
    target = criterion.threshold * criterion.area / SECONDS_PER_DAY + pump
    res = SealResult()
    q0 = section_discharge(snapshot, breach_x, levee_y, flow_sign)
    block = (face_cells(pile, side, breach_x, x, flood_level, bed, obstacle) if criterion.seal_leakage == "series"
             else None)
    still = None
    if block is not None and flood_level is not None and bed is not None:
        barrier = block if obstacle is None else (np.asarray(obstacle, bool) | block)
        reach = flood_connected((np.asarray(bed, float) < flood_level) & ~barrier, side)
        if separates(pile, reach, side):
            still = still_water(snapshot, bed, reach, flood_level, tailwater)
    prev = snapshot
    for _ in range(max_steps):
        layers = [(criterion.seal_layers[0], t)] + [(g, criterion.filter_thickness) for g in criterion.seal_layers[1:]]
        sealed, tons = seal_pile(pile, y, layers, side, x=x, x_range=breach_x, law=criterion.law,
                                 height_cap=height_cap)
        if available_t is not None and sum(tons.values()) > available_t * (1 + 1e-9):
            res.verdict = (f"seal material runs out: {sum(tons.values()):,.0f} t needed for {t:.3g} m, "
                           f"{available_t:,.0f} t available")
            break
        c0 = _time.process_time()
        sealed_last = sealed
        if criterion.seal_leakage == "flow_model":
            snap = solve(sealed, prev, None)
            q_flow = q = section_discharge(snap, breach_x, levee_y, flow_sign)
            q_series = float("nan")
        else:  # the emergent sealed faces closed in the flow model, their seepage by layers in series; water at
            # rest on both sides when the seal separates them (no re-solve)
            if still is not None:
                snap, q_flow = still, 0.0
            else:
                snap = solve(sealed, prev, block)
                q_flow = section_discharge(snap, breach_x, levee_y, flow_sign)
            q_series = series_leakage(snap, pile, layers, side, breach_x, criterion.law, columns=block.any(axis=0))
            q = q_flow + q_series
        v = polder_leakage_check(q, criterion.area, pump, criterion.threshold)
        steady = is_steady(snap)
        res.steps.append(SealStep(t, tons, q, v.net_rise_per_day, v.acceptable and steady, _time.process_time() - c0,
                                  q_flow, q_series, steady, "still water" if still is not None else "re-solved"))
        res.snapshot, prev = snap, snap
        if v.acceptable and not steady:
            res.verdict = (f"not sealed: the re-solve with {t:.3g} m of seal is not steady (leakage {q:.4g} m3/s "
                           f"read from an unsettled flow)")
            break
        if v.acceptable:
            res.sealed = True
            res.verdict = (f"sealed: {t:.3g} m of {criterion.seal_layers[0].name} with "
                           f"{len(criterion.seal_layers) - 1} filter layer(s); leakage {q:.4g} m3/s (from "
                           f"{q0:.4g}), net polder rise {v.net_rise_per_day:.3g} m/day")
            break
        if t >= t_max * (1 - 1e-9):
            res.verdict = (f"not sealed: at max_seal_thickness {t_max:g} m the leakage is {q:.4g} m3/s, net polder "
                           f"rise {v.net_rise_per_day:.3g} m/day above {criterion.threshold:.3g} m/day")
            break
        t = next_thickness(t, q, target, t_max, getattr(criterion, "seal_growth", SEAL_GROWTH))
    else:
        res.verdict = f"not sealed after {max_steps} re-solves (last {res.last.thickness:.3g} m)"
    if not res.verdict:
        res.verdict = "not sealed"
    if block is not None and res.last is not None and compare_flow_model:
        # the same seal with the flow through it left to the flow model (the comparison of the docs)
        snap = solve(sealed_last, res.snapshot, None)
        res.flow_model_leakage = section_discharge(snap, breach_x, levee_y, flow_sign)
    return res




def seal_criterion(setup):
    """The ``polder_leakage`` criterion of *setup* with seal layers and a polder area, or None."""
    for c in getattr(setup.criteria, "items", []):
        if getattr(c, "seal_layers", None) and getattr(c, "area", None) and not getattr(c, "fallback", False):
            return c
    return None


def seal_stage(setup, rec, snapshot):
    """The seal of a closed rock dam in the flow model (module docstring): from the last cycle's restart
    record *rec* (DEM state, resting masses) and field *snapshot*, with *setup*'s domain and solver (and
    its timeline: the seal is delivered after the rock and the polder integrated over that time).
    Returns a :class:`SealResult` or None when the run has no seal (criterion without ``seal``, or a pile
    that is not porous)."""
    crit = seal_criterion(setup)
    if crit is None or setup.remap_mode != "porous":
        return None
    from .delivery import delivery_method
    from .remap import porous_pile

    dom = setup.domain
    pos = np.asarray(rec["dem.state.pos"], float)
    radius = np.asarray(rec["dem.state.radius"], float)
    resting = np.asarray(rec["resting"], bool)
    m = min(len(pos), len(radius), len(resting))
    pile = porous_pile(dom.x, dom.y, dom.bed, pos[:m], radius[:m], resting[:m], law=setup.porous_law)
    if not pile.any:
        return None
    tl = setup.timeline
    flood = float(setup.flood_level if tl is None else tl.flood_level)
    obstacle = np.asarray(snapshot["obstacle"].values, bool) if "obstacle" in snapshot else None
    if obstacle is not None:
        obstacle = obstacle & ~np.asarray(dom.obstacle, bool)  # the pile's emergent cells (the levee is in dom)

    def solve(p, initial, block):  # solved on to its steady state, as the rock stage's end (cycle/rock_end.py)
        from .rock_end import continue_to_steady

        obst = obstacle if block is None else (block if obstacle is None else obstacle | block)
        once = lambda prev: setup.solver.solve(dom.with_porous(p), obstacles=obst, initial=prev)  # noqa: E731
        return continue_to_steady(once, once(initial), getattr(crit, "steady_cap", 1800.0))[0]

    plan = getattr(crit, "seal_plan", None) or {}
    res = seal_dam(solve, pile, snapshot, crit, breach_x=setup.breach_x, levee_y=setup.levee_y, y=dom.y,
                   x=dom.x, thickness0=plan.get("seal_thickness"), max_steps=crit.seal_steps,
                   available_t=crit.seal_available, height_cap=np.maximum(flood - np.asarray(dom.bed, float), 0.0),
                   flood_level=flood, bed=np.asarray(dom.bed, float), compare_flow_model=crit.seal_compare,
                   obstacle=np.asarray(dom.obstacle, bool) if obstacle is None else obstacle | np.asarray(dom.obstacle, bool),
                   tailwater=None if tl is None else tl.tailwater, flow_sign=setup.flow_sign)
    # delivery: the seal's own method after the rock
    if crit.seal_method is not None:
        method = delivery_method(crit.seal_method)
    elif tl is not None:
        method = tl.method
    else:
        method = delivery_method("split_barge")
    if crit.seal_capacity is not None:
        method = method.with_overrides(capacity=crit.seal_capacity)
    start = float(tl.time) if tl is not None else 0.0
    tonnes = sum(res.last.tonnage.values()) if res.last else 0.0
    res.work_s, res.finish_s = seal_delivery(tonnes, method, start, None if tl is None else tl.wind)
    res.start_s, res.method, res.capacity_t_h = start, method.name, method.capacity * HOUR / 1000.0
    if tl is not None and res.last is not None:
        tl._integrate(res.finish_s)  # the polder takes the rock dam's leakage while the seal goes in
        tl.delivered += 1000.0 * tonnes
        tl.record(res.last.leakage, "seal")
    return res


def record_seal(rundir, res: SealResult, setup) -> tuple[bool, str]:
    """Write the seal stage of *res* into the run directory: the manifest's ``metadata.seal`` and the sealed
    field ``sealed.nc``; returns ``(closed, verdict)`` of the run with the seal."""
    info = res.as_dict()
    if setup.timeline is not None:
        info["timeline"] = setup.timeline.state()
    if res.snapshot is not None:
        path = rundir.path / "sealed.nc"
        grid = res.snapshot[[v for v in res.snapshot.data_vars if "particle" not in res.snapshot[v].dims]]
        grid.attrs.update({"title": "breachflow closure run: steady flow with the seal in the pile",
                           "seal_thickness": float(res.last.thickness),
                           "seal_leakage": float(res.last.leakage)})
        grid.to_netcdf(path)
        info["field"] = path.name
    rundir.update_metadata(seal=info)
    return bool(res.sealed), ("" if res.sealed else res.verdict)
