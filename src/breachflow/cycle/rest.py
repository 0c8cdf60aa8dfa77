"""Which masses a closure cycle counts as the pile (docs/theory.md, *The closure cycle*: "resting particles become ... boundaries").

A cycle's DEM ends when every mass is at rest (``e_tol``, or every awake mass slower than ``rest_speed`` for
``rest_time``) or at the safety cap ``max_time``. At the cap some masses still move, and the remap must
decide which of them the flow sees as pile. Chosen by name (``[dem] rest_rule``, :data:`REST_RULES`):

``speed`` (before issue 16): a mass is pile when it is asleep or its centre speed at the cap instant is below
``rest_speed``. A mass that rested, was woken by the changed flow and oscillates on its seat is then in or
out by the phase at which the cap samples it (HEC-RAS nested scene, seed 1 with the brink fix: one mass
placed in cycle 1 read 0.111 m/s > 0.05 m/s at the 10 s cap, dropped out, and the breach discharge
jumped 0.94 → 18.41 m³/s).

``mean_speed`` (default; formerly ``window``, still accepted with a deprecation warning): the settle
loop's own rest test (slower than ``rest_speed`` for ``rest_time``) judged on the mean speed over the
last ``rest_time`` instead of a sample at one instant: a mass is pile when it is
asleep, or its net displacement over the last ``rest_time`` (span ``W``, from the loop's checks
every ``record_interval``, :class:`RestHistory`) is below what ``rest_speed`` covers in ``W``::

    pile_i = active_i ∧ ( asleep_i ∨ |x_i(t) − x_i(t − W)| < v_rest W ),

so a mass jittering, rocking or creeping on its seat stays in whatever its speed at the cap instant,
while a mass carried along (rolling through the gap, sinking through the water column) moves more than
``v_rest W`` and stays out even when the cap catches it momentarily slow — and, still awake, is removed
and counted lost when it leaves the breach area. Physics engines judge sleep candidates the same way,
on the motion over a time span (PhysX ``PxFEMParameters.sleepThreshold``: the linear motion a body may
make in one second). When the DEM converged every active mass is pile under both rules. Limits: a mass
that landed less than ``rest_time`` before the cap joins the pile one cycle later; one rocking with an
amplitude above ``v_rest W / 2`` (1.25 cm at the defaults) can still be in or out by the cap's phase (the
masses of the HEC-RAS case above moved 4-21 mm net over the span at 0.11-0.42 m/s).

The masses counted as pile and still awake are put to sleep for the next cycle (as before; the changed
flow of the next cycle wakes those it really moves).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..registry import Registry

#: the rules deciding which masses the remap counts as the pile at the end of a cycle's DEM
REST_RULES: Registry = Registry("rest rule", "breachflow.rest_rules", default="mean_speed")
#: deprecated rest-rule names and the current ones
RENAMED_RULES = {"window": "mean_speed"}


@dataclass
class RestSample:
    """The masses at the end of a cycle's DEM (SI): ``active``, ``awake`` flags, centre ``speed`` (m/s),
    positions ``pos`` (n, 3) now and ``pos_ref`` at the start of the rest span, ``span`` its length
    (s, >= ``rest_time`` unless the DEM ran shorter), and whether the DEM ``converged`` (every mass at rest)."""

    active: np.ndarray
    awake: np.ndarray
    speed: np.ndarray
    pos: np.ndarray
    pos_ref: np.ndarray
    span: float
    converged: bool


class RestHistory:
    """Positions of the masses at the settle loop's checks, kept over the last ``rest_time``: the oldest
    kept check is the latest at or before ``t − rest_time`` (or the cycle's start), the span's start."""

    def __init__(self, rest_time: float, t: float, pos):
        self.rest_time = float(rest_time)
        self._checks = [(float(t), np.array(pos, copy=True))]

    def add(self, t: float, pos) -> None:
        """Record the positions *pos* at simulated time *t*; drop checks older than the span's start."""
        self._checks.append((float(t), np.array(pos, copy=True)))
        while len(self._checks) > 1 and self._checks[1][0] <= t - self.rest_time + 1e-9:
            self._checks.pop(0)

    def reference(self) -> tuple[float, np.ndarray]:
        """``(W, x(t − W))``: the span's length (s) and the positions at its start."""
        return self._checks[-1][0] - self._checks[0][0], self._checks[0][1]


@REST_RULES.register("speed")
class SpeedRule:
    """Pile = asleep, or centre speed below ``rest_speed`` at the end of the DEM (or the DEM converged)."""

    def members(self, s: RestSample, rest_speed: float) -> np.ndarray:
        return s.active & ((~s.awake) | (s.speed < rest_speed) | s.converged)


@REST_RULES.register("window")  # the former name, kept as an alias (a scenario warns)
@REST_RULES.register("mean_speed")
class MeanSpeedRule:
    """Pile = asleep, or mean speed over the last ``rest_time`` (length ``W``) below ``rest_speed``:
    ``|x(t) − x(t − W)| < rest_speed W`` (module docstring); all active masses when the DEM converged."""

    def members(self, s: RestSample, rest_speed: float) -> np.ndarray:
        drift = np.linalg.norm(np.asarray(s.pos) - np.asarray(s.pos_ref), axis=1)
        return s.active & ((~s.awake) | (drift < rest_speed * s.span) | s.converged)


def pile_members(rule: str, s: RestSample, rest_speed: float) -> np.ndarray:
    """The masses the remap counts as the pile under the rest rule called *rule* (:data:`REST_RULES`)."""
    return REST_RULES.create(rule).members(s, rest_speed)
