"""When the rock stage of a sealed closure may end: a steady re-solve and a crest above the flood.

A rock-fill dam that is to be sealed on its upstream face (``[criteria] polder_leakage`` with ``seal``) ends
its rock stage ("the dam held") only when both hold on the cycle's re-solve:

1. **steady**: the re-solve that judged the criteria reached the solver's own steady-state test (the
   relative rates of change of depth, unit discharge and breach discharge below ``[hydro] tolerance``). A
   re-solve that stops at ``[hydro] t_max`` before that is continued from where it stopped, ``t_max`` at a
   time, up to ``steady_cap`` seconds of simulated time in all (default :data:`STEADY_CAP`); if it is still
   not steady then, the cycle is recorded "not steady" and the dam does not hold: the next cycle places
   more rock. A solver that does not report its steady state (ingested or frozen flow) counts as steady.
2. **emergent**: in every grid column across the gap (the columns of the breach section whose ground at the
   levee line is below the flood level) the pile's crest — the highest bed plus pile height of the column
   over the dam's rows — stands at or above the current flood level. Water that flows over a submerged crest
   no seal on the upstream face stops. With ``rock_end = "overflow"`` the overflow criterion met on the
   steady re-solve is accepted instead of an emergent crest (the dam may then hold with a crest awash).

With ``rock_end = "emergent"`` the crest is known before the flow is: it is the pile's, not the solve's. A
cycle whose crest stands below the flood in some gap column cannot hold whatever the re-solve gives; with
:data:`CONTINUE_SUBMERGED` False its re-solve is not continued to the steady state and the cycle keeps the flow
of its ``t_max`` re-solve, as every earlier cycle of the rock stage does. It is True (continued) by default:
on the typical breach the next cycle's masses, dropped into the less settled flow, left the crest awash one
cycle longer (one more cycle of rock, and a dearer seal), which took back most of the saving
(docs/performance.md, *The rock stage's end*).

The outcome of every judged cycle (steady or not, the simulated time, the lowest and highest crest, the
columns below the flood) is written to the cycle's summary (``rock_end``) and stated in the closure plan.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

#: simulated time (s) a judging re-solve may run in all before it is recorded "not steady"
STEADY_CAP = 1800.0
#: continue the judging re-solve to its steady state also when the crest is below the flood in a gap column
#: (``rock_end = "emergent"``: the dam cannot hold then, the continued solve only refines the flow it is left in)
CONTINUE_SUBMERGED = True
#: the rules: ``emergent`` (steady and the crest above the flood in every gap column) or ``overflow``
#: (steady and the overflow criterion met; the crest may be awash)
ROCK_END_RULES = ("emergent", "overflow")


@dataclass
class RockEnd:
    """The judgement of a rock stage's end on one cycle."""

    rule: str
    steady: bool
    simulated_s: float
    resolves: int
    flood_level: float
    columns: int
    submerged: int
    crest_min: float
    crest_max: float
    emergent: bool
    overflow_ok: bool
    held: bool

    def reason(self) -> str:
        """Why the dam did not hold ("" when it held)."""
        if self.held:
            return ""
        if not self.steady and (self.rule != "emergent" or self.emergent):
            return (f"re-solve not steady after {self.simulated_s:,.0f} s of simulated time "
                    f"({self.resolves} solves); the rock stage goes on")
        return (f"{self.submerged} of {self.columns} gap columns have their crest below the flood level "
                f"{self.flood_level:.2f} m (crest {self.crest_min:.2f}-{self.crest_max:.2f} m)")

    def statement(self) -> str:
        """One line for the plan: the rule and the figures that decided."""
        rule = ("steady re-solve and crest above the flood in every gap column" if self.rule == "emergent"
                else "steady re-solve and overflow criterion met")
        state = "held" if self.held else "not held: " + self.reason()
        return (f"rock stage end ({rule}): {state}; {'steady' if self.steady else 'NOT steady'} after "
                f"{self.simulated_s:,.0f} s simulated; crest {self.crest_min:.2f}-{self.crest_max:.2f} m against "
                f"flood {self.flood_level:.2f} m ({self.columns - self.submerged} of {self.columns} columns emergent)")

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


def gap_crests(x, y, bed, pile_height, breach_x, levee_y: float, flood_level: float):
    """Crest elevation (m) of every grid column across the gap: the highest ``bed + pile_height`` of the
    column over the rows that hold pile anywhere (the levee row when there is no pile). The gap columns are
    those within *breach_x* whose ground at the levee row is below *flood_level*. Returns ``(x, crest)``."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    bed = np.asarray(bed, float)
    height = np.zeros_like(bed) if pile_height is None else np.asarray(pile_height, float)
    j = int(np.argmin(np.abs(y - levee_y)))
    cols = (x >= breach_x[0]) & (x <= breach_x[1]) & (bed[j] < flood_level)
    rows = np.flatnonzero((height > 0).any(axis=1))
    if rows.size == 0:
        rows = np.array([j])
    top = bed[rows][:, cols] + height[rows][:, cols]
    return x[cols], top.max(axis=0) if top.size else np.zeros(0)


def judge(rule: str, steady: bool, simulated_s: float, resolves: int, crests, flood_level: float,
          overflow_ok: bool) -> RockEnd:
    """The rock stage's end by *rule* (module docstring) from the gap's *crests* (m) and the re-solve."""
    if rule not in ROCK_END_RULES:
        raise ValueError(f"rock_end must be one of {ROCK_END_RULES}, got {rule!r}")
    crests = np.asarray(crests, float)
    below = int(np.count_nonzero(~(crests >= flood_level)))
    emergent = bool(crests.size > 0 and below == 0)
    ok = emergent if rule == "emergent" else (emergent or overflow_ok)
    return RockEnd(rule=rule, steady=bool(steady), simulated_s=float(simulated_s), resolves=int(resolves),
                   flood_level=float(flood_level), columns=int(crests.size), submerged=below,
                   crest_min=float(crests.min()) if crests.size else float("nan"),
                   crest_max=float(crests.max()) if crests.size else float("nan"),
                   emergent=emergent, overflow_ok=bool(overflow_ok), held=bool(steady and ok))
