"""Scenario arithmetic: closure window, breach growth, discharge, levee/breach geometry (docs/theory.md, *Closure window*, *Breach growth*).

Public API (every quantity accepts numbers with units; results are SI with ``units``/``long_name`` attrs)::

    closure_window(polder_area=..., inundation_depth=..., surge_height=..., fall_rate=..., ...) -> xr.Dataset
    breach_length(equation, development_time, surge_height=..., levee=..., max_length=...) -> xr.DataArray
    max_breach_length(equation, surge_height) -> xr.DataArray
    breach_discharge(surge_height, breach_length, mean_velocity="3 m/s")      # area x velocity
    weir_discharge(head, bottom_width=..., wall_slope=..., coefficient=...)   # broad-crested weir
    flood_preset(name), flood_presets(kind)                                   # report Tables 2.3, 2.4
    load_scenario(path) -> Scenario; run_scenario(path_or_scenario); model_problem()
"""
from .calculator import ScenarioResult, model_problem, run_scenario, typical_breach_growth
from .config import Scenario, load_scenario, parse_scenario, register_section
from .discharge import WEIR_COEFFICIENT_RANGE, breach_discharge, weir_discharge
from .geometry import BreachGeometry, BreachScene, LeveeGeometry, typical_breach
from .growth import breach_length, growth_equations, max_breach_length, max_length_equations
from .hydrograph import LinearHydrograph, MeasuredHydrograph, first_crossing
from .presets import FloodPreset, flood_preset, flood_presets
from .stone import StoneEstimate, stone_size
from .wind import CRANE_WIND_LIMITS, WindRecord
from .window import closure_window

__all__ = [
    "closure_window", "breach_length", "max_breach_length", "breach_discharge", "weir_discharge",
    "WEIR_COEFFICIENT_RANGE", "growth_equations", "max_length_equations",
    "flood_preset", "flood_presets", "FloodPreset", "load_scenario", "parse_scenario", "register_section",
    "Scenario", "run_scenario", "model_problem", "typical_breach_growth", "ScenarioResult",
    "LinearHydrograph", "MeasuredHydrograph", "first_crossing", "WindRecord", "CRANE_WIND_LIMITS",
    "BreachGeometry", "BreachScene", "LeveeGeometry", "typical_breach", "stone_size", "StoneEstimate",
]
