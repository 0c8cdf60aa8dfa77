"""Compile breachflow's numba kernels once, into numba's on-disk cache (``cache=True``).

``python -m breachflow.warmup`` (run by ``tasks.py`` right after installing) runs a short, coarse version
of the embedded default closure scenario — 3 m cells, short solves, two cycles, 6 s of DEM each (long
enough for masses to come to rest, so the porous pile and the incremental pile top are computed) — in a
temporary directory. That calls every kernel of a closure run (solver, DEM contacts and integrators,
fluid forces, the many-steps-per-call DEM loop of the cycle's scene (:mod:`breachflow.coupling.steploop`),
sampling, remap) with the argument types of a real run, so numba compiles and caches each one; a user's
first ``breachflow run`` then loads them from the cache instead of compiling (most of the CPU time of a
first run on an empty cache; see docs/performance.md). Where the cache lives is numba's choice (``NUMBA_CACHE_DIR``,
which ``tasks.py`` sets to ``.numba_cache``).
"""
from __future__ import annotations

import re
import sys
import tempfile
import time

#: (pattern, replacement) edits of the default scenario that make the warm-up run short
_EDITS = (
    (r'resolution = "[^"]*"', 'resolution = "3 m"'),
    (r't_max_initial = "[^"]*"', 't_max_initial = "20 s"'),
    (r't_max = "[^"]*"', 't_max = "5 s"'),
    (r'max_time = "[^"]*"', 'max_time = "6 s"'),
    (r"max_cycles = \d+", "max_cycles = 2"),
)


def warm_up_scenario() -> str:
    """The default scenario's text with the edits of :data:`_EDITS` (each must apply exactly once)."""
    from .cycle.main import default_scenario_text

    text = default_scenario_text()
    for pat, new in _EDITS:
        text, n = re.subn(pat, new, text)
        if n != 1:
            raise RuntimeError(f"warm-up: pattern {pat!r} matched {n} times in the default scenario")
    return text


def warm_up() -> float:
    """Run the short closure of :func:`warm_up_scenario`; returns its CPU time (s)."""
    from .cycle.config import closure_setup
    from .cycle.driver import ClosureRun
    from .scenario.config import parse_scenario

    c0 = time.process_time()
    text = warm_up_scenario()
    with tempfile.TemporaryDirectory(prefix="breachflow-warmup-") as tmp:
        ClosureRun(closure_setup(parse_scenario(text)), tmp + "/run", text).run()
    warm_up_dem()
    return time.process_time() - c0


def warm_up_dem() -> None:
    """Two spheres on a plane without force models: the many-steps-per-call DEM kernel of dry scenes with
    planes (:mod:`breachflow.dem.steploop`), which a closure run (terrain and fluid forces:
    :mod:`breachflow.coupling.steploop`) does not use."""
    from .dem import DemSimulation, Material, Plane

    rock = Material(density=2650, kn=1e7, friction=0.5, c_cn=4e4)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), rock)])
    sim.add_particles([[0.0, 0.0, 0.6], [0.0, 0.0, 1.8]], 0.5, rock)
    sim.run_to_equilibrium(1e-6, max_steps=200)
    sim.step(10)


def main() -> int:
    cpu = warm_up()
    print(f"[breachflow] numba kernels compiled and cached ({cpu:.1f} CPU s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
