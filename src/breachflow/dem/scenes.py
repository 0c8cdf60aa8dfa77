"""Small reusable scenes: a rough base of fixed spheres and pouring a pile (tests, benchmarks, examples).

A pile of frictional spheres needs a rough base: on a smooth plane, spheres without rolling resistance
roll away and the pile spreads into a monolayer.
"""
from __future__ import annotations

import math

import numpy as np

from .simulation import DemSimulation
from .state import Material


def rough_base(sim: DemSimulation, half_width: float, diameter: float, material: Material | None = None, *,
               rng=None, spread: float = 0.0) -> np.ndarray:
    """Fix a square (3-D) or a row (2-D mode) of spheres resting on z = 0, centred on the origin;
    *spread* > 0 adds random gaps up to spread*diameter between neighbours (an irregular base)."""
    r = diameter / 2
    rng = rng or np.random.default_rng(0)
    k = int(math.ceil(half_width / diameter))
    steps = diameter * (1.0 + spread * rng.random(2 * k))
    xs = np.concatenate([[0.0], np.cumsum(steps)])
    xs -= xs.mean()
    if sim.lmask[1] == 0.0:
        pos = np.column_stack([xs, np.zeros_like(xs), np.full_like(xs, r)])
    else:
        gx, gy = np.meshgrid(xs, xs)
        pos = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, r)])
    idx = sim.add_particles(pos, r, material)
    sim.fix_particles(idx)
    return idx


def drop_batch(sim: DemSimulation, k: int, diameter: float, material: Material | None = None, *, rng=None,
               jitter: float = 0.05, gap: float = 1.5, size_spread: float = 0.0) -> np.ndarray:
    """Insert *k* spheres in a vertical column above the centre of the current top (report: release
    from a crane above the pile); small random horizontal offsets break the symmetry."""
    rng = rng or np.random.default_rng()
    s = sim.state
    top = float(s.pos[s.active, 2].max()) + diameter / 2 if s.n else 0.0
    z = top + gap * diameter + np.arange(k) * 1.2 * diameter
    xy = rng.uniform(-jitter, jitter, (k, 2)) * diameter
    if sim.lmask[1] == 0.0:
        xy[:, 1] = 0.0
    radius = diameter / 2 * (1.0 - size_spread * rng.random(k))
    return sim.add_particles(np.column_stack([xy, z]), radius, material)


def repose_angle(sim: DemSimulation, movable: np.ndarray, diameter: float, base_top: float) -> float:
    """Angle of repose (degrees) of a pile centred on x = y = 0: the slope of the straight line through
    the pile summit and the outer toes, ``atan(height / toe_radius)``.

    height: highest sphere top above the base top; toe radius: the 90th percentile of the horizontal
    distances of the pile's spheres in the lowest layer (which trims single runaways).
    """
    s = sim.state
    p = s.pos[movable][s.active[movable]]
    rho = np.hypot(p[:, 0], p[:, 1])
    z_top = p[:, 2] + diameter / 2
    height = float(z_top.max() - base_top)
    low = rho[p[:, 2] < base_top + diameter]
    if low.size == 0 or height <= 0:
        return 0.0
    toe = float(np.percentile(low, 90)) + diameter / 2
    return math.degrees(math.atan2(height, toe))
