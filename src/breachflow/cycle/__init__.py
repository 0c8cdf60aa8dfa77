"""The closure cycle <g> (docs/theory.md, *The closure cycle*): placement, DEM settling, remap, re-solve, end criteria."""
from .criteria import CriterionResult, CycleContext, EndCriteria, criteria

__all__ = ["CriterionResult", "CycleContext", "EndCriteria", "criteria"]
