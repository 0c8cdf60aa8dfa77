"""Fluid forces in the DEM step: the compiled many-steps loop of the DEM with the fluid forces of
:mod:`breachflow.fluid` (drag, added mass, buoyancy) evaluated inside it, and the integrators that need
the fluid. The one place that builds on both :mod:`breachflow.dem` and :mod:`breachflow.fluid`."""
