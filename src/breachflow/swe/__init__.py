"""Embedded 2-D shallow-water solver (docs/theory.md, *Shallow-water equations*): finite volumes on a structured grid, hydrostatic
reconstruction (Audusse et al. 2004) with HLL/HLLC fluxes, MUSCL + SSP-RK2, implicit Manning friction,
wetting and drying, CFL time step, level / discharge / outflow / wall boundaries and obstacle cells."""
from .solver import SWEOptions, SWESimulation, SWESolver, ConvergenceHistory

__all__ = ["SWEOptions", "SWESimulation", "SWESolver", "ConvergenceHistory"]
