"""The closure cycle <g> (SPEC §7): placement, DEM settling, remap, re-solve, end criteria."""
from .criteria import CriterionResult, CycleContext, EndCriteria, criteria

__all__ = ["CriterionResult", "CycleContext", "EndCriteria", "criteria"]
