"""Masses carried out of the breach area, and the verdict when the chosen masses cannot close the breach.

The breach area
---------------
The DEM of a closure cycle keeps only the masses that can still take part in the closure: the box
``|x| <= B/2 + D_max`` along the levee and ``-(c/2 + H m_F + D_max) <= y <= c/2 + H m_P + D_max`` across
it (scene coordinates: levee centreline ``y = 0``, flood side ``y < 0``; ``B`` breach length, ``c`` crown
width, ``H`` levee height, ``m_F``/``m_P`` the slopes 1V:mH, ``D_max`` the largest mass diameter), i.e.
the levee's footprint over the breach plus one mass diameter. A mass whose centre leaves it (in practice:
rolled or carried downstream past the protected-side toe) is removed from the DEM (it costs nothing any
more) and counted as lost: number and tonnage per cycle and in total. ``[closure] area = [x0, x1, y0, y1]``
overrides the box.

Verdict
-------
A run ends with a "not closable" verdict instead of running into ``max_cycles`` when a cycle shows that
the masses are carried away faster than they build up — the closure engineer's test of a dumping
rate against an eroding flow: more of a dumping was carried out of the gap than stayed, and the flow
there is strong enough to move the masses. Both must hold (:func:`cannot_close`):

1. **Losses against the placement they belong to** (:func:`carried_away_faster`). Every mass is counted
   against the tonnage placed with it, whenever it leaves: masses still rolling when a cycle's DEM stops,
   or knocked off the pile later, may leave in a later cycle. With ``P_k`` the tonnage placed in cycle
   ``k`` and ``L_k`` the part of it carried out of the breach area so far, cycle ``g`` gives the verdict
   when, for a cycle ``k <= g`` whose masses left in cycle ``g`` (:class:`CycleLosses`)::

       L_k > loss_limit * P_k

   (``loss_limit`` default 0.5): more than half of a dumping was carried away, at whatever pace. For
   ``k = g`` this is the cycle's own batch; an older mass is no longer counted against this cycle's
   placement, nor can one straggler decide (it is one of its batch). A cycle that placed nothing gives no
   verdict (nothing was tried), nor does a closed breach. A pile that loses a few masses of each of many
   cycles gives none either: such losses show in ``losses_flagged`` and the cycle count.
2. **The flow exceeds what the masses withstand** (:func:`flow_moves_masses`): the largest speed in the
   breach area of the field the masses felt (the gap speed, depth-averaged) exceeds Izbash's
   exposed-stone speed for the placed masses' median diameter, or the speed at a mass's centre on the
   bed there (the velocity profile's factor times the gap speed) exceeds the lone-mass rolling speed on
   the bare bed (below). Below both, the flow cannot be what carries the masses away — masses knocked
   off the pile's flank by the next ones, or rolling down a slope, are a placement's scatter, not a
   verdict on the mass size; such losses are counted and, beyond ``loss_limit`` of all placed tonnage,
   flagged (``losses_flagged``), and a run that never closes ends at ``max_cycles`` saying so.

Why not the tonnage lost in a cycle over that cycle's placement (a simpler rule): masses
still rolling from earlier cycles, or pile masses knocked loose, leave in a later cycle; counted against
that cycle's five masses they ended the default scene (seed 2, tolerance 2e-3) "not closable" at 26 m³/s
(of the open breach's 85.6): 34.1 t lost of 51.4 t placed, but two of the three masses were cycle 7's,
knocked off the pile's top onto the intact levee and the flood-side slope (cycle 7 lost 23.7 of its
55.5 t, cycle 8 10.4 of 51.4 t), in a gap speed of 3.80 m/s, below both Izbash's 6.71 m/s and the
5.51 m/s that rolls a lone mass. Nor the tonnage lost in a cycle over the tonnage in play in it (its
placement plus the older masses still moving): masses that roll out slowly never reach the limit — in
the CI scene with 1 m masses free to roll and a 5 s cycle cap every batch leaves two cycles after its
release, and that ratio stays at 4.16 of 12.49 t.

The statement names what was lost and compares the gap speed
with Izbash's critical speed for the masses' diameter (Izbash 1935, *Construction of dams by dumping
stones into flowing water*; Izbash & Khaldre 1970)::

    u_c = C sqrt(2 g Delta D),   Delta = (rho_s - rho_w) / rho_w,

``C = 0.86`` for a stone exposed on top of others, ``1.20`` for one embedded among them — the speed
range in which dumped stones of that size start to be carried away. Losses of more than ``loss_limit``
of all placed tonnage over the run are flagged in the summary even when the breach closes.

Izbash's speeds are for a stone in a bed of stones. The first masses of a closure land on the bare
breach floor, where a lone sphere is held by nothing but its rolling resistance: it rolls once the drag
exceeds ``mu_r`` times its submerged weight (:mod:`breachflow.dem.contact_law`, the moment
``mu_r R F_N`` against the drag's ``F R``), i.e. at the speed (at its centre height)

    u_roll = sqrt(mu_r (rho_s - rho_w) g V / (1/2 rho_w C_D(Re) A)),   V = pi D^3/6, A = pi D^2/4

(:func:`rolling_speed`; ``C_D`` from the run's drag law at ``Re = u_roll D / nu``). For the model's
spheres (``mu_r`` 0.3) this lies below Izbash's exposed-stone speed (D = 4 m, report drag law: 8.05
against 9.78 m/s), so masses can be carried off a bare floor by a flow slower than Izbash's speed. The
verdict names both and which one the flow exceeds, with the depth-averaged gap speed converted to the
speed at a mass's centre on the bed by the run's velocity profile; it counts the masses lost in the
cycle separately from those placed in it (masses still rolling at the end of a cycle may leave in the
next one).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Izbash coefficients (exposed stone, embedded stone)
IZBASH_C = (0.86, 1.20)
#: default fraction of a cycle's placement whose loss (whenever its masses leave, in a flow that moves them)
#: ends the run with a "not closable" verdict; also the fraction of all placed tonnage above which losses are flagged
LOSS_LIMIT = 0.5


def breach_area(scene, d_max: float) -> tuple[float, float, float, float]:
    """``(x0, x1, y0, y1)`` (m) of the breach area of a :class:`~breachflow.scenario.geometry.BreachScene`."""
    lev = scene.levee
    half = 0.5 * scene.breach.length + d_max
    return (-half, half, -(0.5 * lev.crown_width + lev.height * lev.flood_slope + d_max),
            0.5 * lev.crown_width + lev.height * lev.protected_slope + d_max)


def izbash_speed(diameter, density, rho_w: float = 1000.0, g: float = 9.80665, c: float = IZBASH_C[0]):
    """Izbash's critical flow speed ``C sqrt(2 g Delta D)`` (m/s) of a stone of *diameter* (m) and *density*."""
    delta = (np.asarray(density, float) - rho_w) / rho_w
    return c * np.sqrt(2.0 * g * delta * np.asarray(diameter, float))


def gap_speed(snapshot, area) -> float:
    """Largest depth-averaged speed (m/s) over wet, open cells inside the breach *area*."""
    return gap_speed_and_depth(snapshot, area)[0]


def gap_speed_and_depth(snapshot, area) -> tuple[float, float]:
    """:func:`gap_speed` and the water depth (m) in the cell where it occurs (0, 0 when none is wet)."""
    x = snapshot["x"].values
    y = snapshot["y"].values
    X, Y = np.meshgrid(x, y)
    inside = (X >= area[0]) & (X <= area[1]) & (Y >= area[2]) & (Y <= area[3])
    depth = snapshot["depth"].values
    wet = depth > 1e-6
    if "obstacle" in snapshot:
        wet &= ~snapshot["obstacle"].values.astype(bool)
    sel = inside & wet
    if not sel.any():
        return 0.0, 0.0
    speed = np.where(sel, np.hypot(snapshot["u"].values, snapshot["v"].values), -np.inf)
    k = np.unravel_index(int(np.argmax(speed)), speed.shape)
    return float(speed[k]), float(depth[k])


def rolling_speed(diameter: float, density: float, rolling_friction: float, drag_law="report",
                  rho_w: float = 1000.0, nu_w: float = 1.0e-6, g: float = 9.80665) -> float:
    """Flow speed (m/s, at the centre) that rolls a lone submerged sphere on a flat bed: the drag
    ``1/2 rho_w C_D(Re) A u^2`` equals ``rolling_friction`` times the submerged weight (module docstring);
    fixed point on ``C_D(Re)``. 0 without rolling resistance."""
    from ..fluid.drag import DRAG_LAWS

    law = DRAG_LAWS.create(drag_law)
    d = float(diameter)
    w_sub = float(rolling_friction) * (float(density) - rho_w) * g * math.pi * d ** 3 / 6.0
    if w_sub <= 0.0:
        return 0.0
    area = 0.25 * math.pi * d * d
    u = 1.0
    for _ in range(100):
        cd = float(law.cd(u * d / nu_w))
        new = math.sqrt(w_sub / (0.5 * rho_w * cd * area))
        if abs(new - u) <= 1e-10 * new:
            return new
        u = new
    return u


def verdict_drag_law(dem, placement):
    """The drag law of the "not closable" verdict's :func:`rolling_speed`: the run's (``dem.drag_law``), or for a
    mix of closure materials whose drag coefficients differ, the constant law of their tonnage-weighted mean
    (each mass in the DEM keeps its own)."""
    p = None if placement is None else placement.dem_parameters()
    if p is None or p["drag_coefficient"] is not None or p.get("drag_coefficient_mean") is None:
        return dem.drag_law
    from ..fluid.drag import DRAG_LAWS

    return DRAG_LAWS.create("constant", value=p["drag_coefficient_mean"])


def not_closable_verdict(cycle: int, lost: int, placed: int, lost_t: float, placed_t: float, diameters,
                         density, speed: float, *, lost_placed: int | None = None, roll_speed: float | None = None,
                         bed_factor: float = 1.0, cohort: CycleLosses | None = None) -> str:
    """The statement a run ends with when :func:`cannot_close` holds for a cycle.

    *lost* masses (*lost_t* t) left the breach area in *cycle*, *lost_placed* of them placed in it (None:
    not known); *placed* masses (*placed_t* t) were placed; *cohort* the cycle's :class:`CycleLosses` when
    an earlier cycle's placement decides (None: not stated). *speed* is the gap speed (depth-averaged) of the
    field the masses felt; *bed_factor* the velocity profile's factor at the centre of a mass resting on
    the bed there (the speed it feels is ``bed_factor * speed``); *roll_speed* the speed at which a lone
    mass rolls on the bare bed (:func:`rolling_speed`; None: not stated)."""
    d = np.asarray(diameters, float)
    rho = float(np.median(density))
    dtxt = f"{d.min():.3g} m" if np.ptp(d) < 1e-9 else f"{d.min():.3g}-{d.max():.3g} m"
    lo, hi = (float(izbash_speed(float(np.median(d)), rho, c=c)) for c in IZBASH_C)
    felt = bed_factor * speed
    who = f"{lost} masses ({lost_t:.1f} t)"
    if lost_placed is not None and lost_placed != lost:
        who += f", {lost_placed} of them placed in this cycle,"
    cmp = "exceeds" if speed > lo else "is below"
    text = (f"not closable with D = {dtxt} masses of {rho:.0f} kg/m3: in cycle {cycle}, {who} were carried out "
            f"of the breach area ({placed} masses, {placed_t:.1f} t placed in it{_cohort(cohort, cycle)}); "
            f"gap speed {speed:.2f} m/s "
            f"(depth-averaged")
    if abs(bed_factor - 1.0) > 1e-9:
        text += f"; {felt:.2f} m/s at the centre of a mass on the bed"
    text += (f") {cmp} the Izbash critical speed {lo:.2f}-{hi:.2f} m/s for D = {float(np.median(d)):.3g} m "
             f"(C = {IZBASH_C[0]}-{IZBASH_C[1]}, a stone in a bed of stones)")
    if roll_speed is not None:
        rel = "above" if felt > roll_speed else "below"
        text += (f"; the speed at a mass's centre is {rel} the {roll_speed:.2f} m/s at which a lone mass rolls "
                 f"on the bare bed (drag > rolling friction x submerged weight)")
        if felt <= lo and felt > roll_speed:
            text += ", which governs here"
    return text


def _cohort(c, cycle) -> str:
    if c is None or c.cohort in (0, cycle):
        return ""
    return (f"; cycle {c.cohort}'s placement has lost {c.cohort_lost:.1f} of its {c.cohort_placed:.1f} t "
            f"({c.cohort_fraction:.0%})")


def losses_flagged(lost_t: float, placed_t: float, limit: float) -> bool:
    """True when more than *limit* of the placed tonnage over the run was lost."""
    return placed_t > 0 and lost_t > limit * placed_t and math.isfinite(lost_t)


@dataclass(frozen=True)
class CycleLosses:
    """One cycle's tonnage (t): *placed* in it; *lost* (carried out of the breach area in it), of which
    *lost_placed* placed in it. *cohort*: of the cycles whose masses left in this one, the cycle whose
    placement has lost the largest share so far (0: no mass left), *cohort_placed* its placement and
    *cohort_lost* the part of it carried away up to now (in this cycle or before)."""

    placed: float
    lost: float
    lost_placed: float
    cohort: int = 0
    cohort_placed: float = 0.0
    cohort_lost: float = 0.0

    @property
    def cohort_fraction(self) -> float:
        """Share of the cohort's placement carried away so far (0 without a cohort)."""
        return self.cohort_lost / self.cohort_placed if self.cohort_placed > 0 else 0.0


def cycle_losses(mass, placed_cycle, active_before, active_after, cycle: int) -> CycleLosses:
    """:class:`CycleLosses` of *cycle* from the DEM's per-slot arrays: *mass* (kg); *placed_cycle* the cycle
    each slot was released in (its length is the number of slots used); *active_before* after this cycle's
    release, *active_after* when its DEM stopped (a slot lost in an earlier cycle is inactive in both)."""
    pc = np.asarray(placed_cycle, int)
    n = pc.size
    m = np.asarray(mass, float)[:n] / 1000.0
    after = np.asarray(active_after, bool)[:n]
    lost_now = np.asarray(active_before, bool)[:n] & ~after
    new = pc == cycle
    best = (0, 0.0, 0.0)
    for k in np.unique(pc[lost_now]):
        sel = pc == k
        placed_k, lost_k = float(m[sel].sum()), float(m[sel & ~after].sum())
        if placed_k > 0 and (best[0] == 0 or lost_k * best[1] > best[2] * placed_k):
            best = (int(k), placed_k, lost_k)
    return CycleLosses(placed=float(m[new].sum()), lost=float(m[lost_now].sum()),
                       lost_placed=float(m[lost_now & new].sum()), cohort=best[0], cohort_placed=best[1],
                       cohort_lost=best[2])


def carried_away_faster(losses: CycleLosses, limit: float) -> bool:
    """Part 1 of the verdict (module docstring): something was placed in the cycle, and more than *limit*
    of the placement of a cycle whose masses left in it has been carried away, ``L_k > limit * P_k``."""
    if not (losses.placed > 0 and losses.cohort_placed > 0 and math.isfinite(losses.cohort_lost)):
        return False
    return losses.cohort_lost > limit * losses.cohort_placed


def flow_moves_masses(speed: float, izbash: float, felt_speed: float | None = None,
                      roll_speed: float | None = None) -> bool:
    """Part 2 of the verdict: the depth-averaged gap *speed* exceeds Izbash's (exposed-stone) speed
    *izbash*, or the speed at a mass's centre on the bed *felt_speed* exceeds the lone-mass rolling speed
    *roll_speed* (None: not judged)."""
    if speed > izbash:
        return True
    return felt_speed is not None and roll_speed is not None and felt_speed > roll_speed


def cannot_close(losses: CycleLosses, limit: float, *, speed: float, izbash: float, felt_speed: float | None = None,
                 roll_speed: float | None = None, closed: bool = False) -> bool:
    """The verdict rule (module docstring): not *closed*, :func:`carried_away_faster` and
    :func:`flow_moves_masses`."""
    return (not closed and carried_away_faster(losses, limit)
            and flow_moves_masses(speed, izbash, felt_speed, roll_speed))
