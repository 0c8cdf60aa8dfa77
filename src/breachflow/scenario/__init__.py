"""Scenario arithmetic: closure window, breach growth, discharge, levee/breach geometry (SPEC §2–3)."""
from .geometry import BreachGeometry, BreachScene, LeveeGeometry, typical_breach

__all__ = ["BreachGeometry", "BreachScene", "LeveeGeometry", "typical_breach"]
