"""When the rock stage of a sealed closure may end: a steady re-solve and a crest above the flood.

A rock-fill dam that is to be sealed on its upstream face (``[criteria] polder_leakage`` with ``seal``) ends
its rock stage ("the dam held") only when both hold on the cycle's re-solve:

1. **steady**: the re-solve that judged the criteria reached the solver's own steady-state test (the
   relative rates of change of depth, unit discharge and breach discharge below ``[hydro] tolerance``). A
   re-solve that stops at ``[hydro] t_max`` before that is continued from where it stopped, ``t_max`` at a
   time, up to ``steady_cap`` seconds of simulated time in all (default :data:`STEADY_CAP`); if it is still
   not steady then, the cycle is recorded "not steady" and the dam does not hold: the next cycle places
   more rock. A solver that does not report its steady state (ingested or frozen flow) counts as steady.
2. **emergent**: the pile's crest, read from the masses themselves, stands at or above the current flood
   level all along the gap. The crest above a point ``x`` of the gap (the breach section along the levee line)
   is the highest top ``z_i + r_i`` of a resting unit whose silhouette covers it (``|x - x_i| <= r_i``), or the
   ground at the levee line where that is higher (:func:`gap_crests`, :mod:`~breachflow.cycle.crest`). A
   stretch of the gap where it stays below the flood and that is wider than a unit (the mean of the
   placement's smallest and largest diameter) is an *opening*: water flows over it, no seal on the upstream
   face stops that, and the next cycle's units fit into it. A narrower stretch is a *notch*, a void between
   units that stand above the flood, which no further unit fits into; notches are counted and reported but
   do not keep the rock stage going. With
   ``rock_end = "overflow"`` the overflow criterion met on the steady re-solve is accepted instead of an
   emergent crest (the dam may then hold with a crest awash).

   The crest is the masses', not the flow grid's: it is the same reading whatever the cell size. A crest
   read as the highest pile top of each grid column hid openings narrower than a cell, so a coarse grid
   ended its rock stage earlier, on a lower crest, than a fine one (docs/verdict-check.md, *The crest
   from the units, and rock at the breach heads*).

With ``rock_end = "emergent"`` the crest is known before the flow is: it is the pile's, not the solve's. A
cycle whose crest leaves an opening cannot hold whatever the re-solve gives; with
:data:`CONTINUE_SUBMERGED` False its re-solve is not continued to the steady state and the cycle keeps the flow
of its ``t_max`` re-solve, as every earlier cycle of the rock stage does. It is True (continued) by default:
on the typical breach the next cycle's masses, dropped into the less settled flow, left the crest awash one
cycle longer (one more cycle of rock, and a dearer seal), which took back most of the saving
(docs/performance.md, *The rock stage's end*).

The outcome of every judged cycle (steady or not, the simulated time, the lowest and highest crest, the
openings and the widest of them) is written to the cycle's summary (``rock_end``) and stated in the closure plan.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .crest import CREST_STEP, crest_profile, openings, stations

#: simulated time (s) a judging re-solve may run in all before it is recorded "not steady"
STEADY_CAP = 1800.0
#: continue the judging re-solve to its steady state also when the crest leaves an opening below the flood
#: (``rock_end = "emergent"``: the dam cannot hold then, the continued solve only refines the flow it is left in)
CONTINUE_SUBMERGED = True
#: the rules: ``emergent`` (steady and no opening below the flood along the gap) or ``overflow``
#: (steady and the overflow criterion met; the crest may be awash)
ROCK_END_RULES = ("emergent", "overflow")


@dataclass
class RockEnd:
    """The judgement of a rock stage's end on one cycle. Widths in m along the gap: ``gap_width`` the part of
    the breach section whose ground is below the flood, ``submerged_width`` the part of it whose crest is;
    ``openings`` the stretches below the flood wider than ``unit_diameter`` (they keep the rock stage going),
    ``notches`` the narrower ones (voids between emergent units), ``widest_opening`` the widest of either."""

    rule: str
    steady: bool
    simulated_s: float
    resolves: int
    flood_level: float
    gap_width: float
    submerged_width: float
    openings: int
    notches: int
    widest_opening: float
    unit_diameter: float
    crest_min: float
    crest_max: float
    emergent: bool
    overflow_ok: bool
    held: bool

    @classmethod
    def from_dict(cls, d: dict) -> RockEnd | None:
        """The judgement back from a run's summary (:meth:`as_dict`); None for a summary written before the
        crest was read from the masses (it has no ``openings``)."""
        if not all(k in d for k in cls.__dataclass_fields__):
            return None
        return cls(**{k: d[k] for k in cls.__dataclass_fields__})

    def reason(self) -> str:
        """Why the dam did not hold ("" when it held)."""
        if self.held:
            return ""
        if not self.steady and (self.rule != "emergent" or self.emergent):
            return (f"re-solve not steady after {self.simulated_s:,.0f} s of simulated time "
                    f"({self.resolves} solves); the rock stage goes on")
        if self.gap_width <= 0.0:
            return f"no part of the breach section lies below the flood level {self.flood_level:.2f} m"
        return (f"the crest leaves {self.openings} opening(s) wider than a unit ({self.unit_diameter:.2f} m) below "
                f"the flood level {self.flood_level:.2f} m: {self.submerged_width:.2f} m of the {self.gap_width:.2f} m "
                f"gap below it (widest {self.widest_opening:.2f} m; crest {self.crest_min:.2f}-{self.crest_max:.2f} m)")

    def statement(self) -> str:
        """One line for the plan: the rule and the figures that decided."""
        rule = ("steady re-solve and crest above the flood all along the gap" if self.rule == "emergent"
                else "steady re-solve and overflow criterion met")
        state = "held" if self.held else "not held: " + self.reason()
        return (f"rock stage end ({rule}): {state}; {'steady' if self.steady else 'NOT steady'} after "
                f"{self.simulated_s:,.0f} s simulated; crest {self.crest_min:.2f}-{self.crest_max:.2f} m against "
                f"flood {self.flood_level:.2f} m ({self.openings} openings wider than {self.unit_diameter:.2f} m, "
                f"{self.notches} narrower; {self.submerged_width:.2f} of {self.gap_width:.2f} m below)")

    def as_dict(self) -> dict:
        d = asdict(self)
        d["reason"] = self.reason()
        return d


def is_steady(snapshot) -> bool:
    """The solver's own steady-state flag of *snapshot* (``steady_state`` attribute); True when absent."""
    flag = getattr(snapshot, "attrs", {}).get("steady_state")
    return True if flag is None else bool(int(flag))


def simulated_time(snapshot) -> float:
    """Simulated time (s) of the solve that produced *snapshot* (0 when not stated)."""
    return float(getattr(snapshot, "attrs", {}).get("simulated_time_s", 0.0))


def continue_to_steady(solve, snapshot, cap: float = STEADY_CAP):
    """Continue *solve* (``solve(initial) -> snapshot``, one solve of at most the solver's ``t_max``) from
    *snapshot* until it is steady or the simulated time of all solves reaches *cap* (s).
    Returns ``(snapshot, steady, simulated seconds, number of solves)`` (the first solve included)."""
    total = simulated_time(snapshot)
    n = 1
    steady = is_steady(snapshot)
    while not steady and total < cap:
        nxt = solve(snapshot)
        dt = simulated_time(nxt)
        if dt <= 0.0:  # the solver does not advance time: nothing more to gain
            break
        snapshot, total, n = nxt, total + dt, n + 1
        steady = is_steady(snapshot)
    return snapshot, steady, total, n


def gap_crests(pos, radius, resting, x, y, bed, breach_x, levee_y: float, flood_level: float,
               step: float = CREST_STEP):
    """The pile's crest across the gap (:func:`~breachflow.cycle.crest.crest_profile`): along the breach section
    *breach_x* at the levee line, every *step* m, the highest top of a resting unit (*pos* (n, 3), *radius*
    (n,), *resting* (n,) bool) whose silhouette covers the point, or the ground there (the grid's *bed* on the
    row nearest *levee_y*, linear between its columns *x*) where that is higher. Only the points whose ground
    is below *flood_level* (the water part of the gap) are returned, as ``(x, crest)`` (m)."""
    x = np.asarray(x, float)
    bed = np.asarray(bed, float)
    j = int(np.argmin(np.abs(np.asarray(y, float) - levee_y)))
    x0, x1 = float(min(breach_x)), float(max(breach_x))
    xs = x0 + stations(x1 - x0, step)
    ground = np.interp(xs, x, bed[j])
    pos = np.asarray(pos, float).reshape(-1, 3)
    m = min(len(pos), len(radius), len(resting))
    keep = np.flatnonzero(np.asarray(resting[:m], bool) & np.isfinite(pos[:m]).all(axis=1))
    r = np.asarray(radius, float)[keep]
    crest = crest_profile(xs, ground, pos[keep, 0], pos[keep, 2] + r, r)
    water = ground < flood_level
    return xs[water], crest[water]


def judge(rule: str, steady: bool, simulated_s: float, resolves: int, xs, crests, flood_level: float,
          overflow_ok: bool, unit_diameter: float = 0.0, step: float = CREST_STEP) -> RockEnd:
    """The rock stage's end by *rule* (module docstring) from the gap's crest profile (*xs*, *crests*, m, from
    :func:`gap_crests`; *step* their spacing when there is only one point) and the re-solve. An opening
    counts when it is wider than *unit_diameter* (m): a narrower one is a void between emergent units that no
    further unit fits into."""
    if rule not in ROCK_END_RULES:
        raise ValueError(f"rock_end must be one of {ROCK_END_RULES}, got {rule!r}")
    crests = np.asarray(crests, float)
    xs = np.asarray(xs, float)
    if xs.size > 1:  # the points' own spacing (gap_crests divides the section evenly, at most *step* apart)
        step = float(np.min(np.diff(xs)))
    widths = [b - a for a, b in openings(xs, crests, flood_level, step)]
    wide = [w for w in widths if w > unit_diameter]
    emergent = bool(crests.size > 0 and not wide)
    ok = emergent if rule == "emergent" else (emergent or overflow_ok)
    return RockEnd(rule=rule, steady=bool(steady), simulated_s=float(simulated_s), resolves=int(resolves),
                   flood_level=float(flood_level), gap_width=float(crests.size * step),
                   submerged_width=float(sum(widths)), openings=len(wide), notches=len(widths) - len(wide),
                   widest_opening=float(max(widths)) if widths else 0.0, unit_diameter=float(unit_diameter),
                   crest_min=float(crests.min()) if crests.size else float("nan"),
                   crest_max=float(crests.max()) if crests.size else float("nan"),
                   emergent=emergent, overflow_ok=bool(overflow_ok), held=bool(steady and ok))
