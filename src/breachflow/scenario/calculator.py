"""The scenario calculator: closure window + breach size for a scenario file or the report's model problem.

``breachflow run`` calls :func:`model_problem` (until the closure simulation becomes the default) and
``breachflow run scenario.toml`` calls :func:`run_scenario`.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import BreachflowWarning
from .config import Scenario, load_scenario
from .geometry import BreachScene, typical_breach
from .growth import breach_length, max_breach_length
from .window import closure_window

MODEL_PROBLEM_FILES = ("model_problem_hurricane.toml", "model_problem_riverine.toml")


@dataclass
class ScenarioResult:
    """Results of one scenario: the closure-window Dataset and, when asked for, breach growth."""

    name: str
    description: str
    window: xr.Dataset | None
    growth: xr.DataArray | None = None
    max_length: xr.DataArray | None = None


def run_scenario(scenario: Scenario | str | Path) -> ScenarioResult:
    """Run the calculator on a scenario (object or TOML path)."""
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    window = closure_window(**scenario.window_kwargs()) if "flood" in scenario else None
    growth = max_len = None
    breach = scenario.get("breach")
    if breach is not None and breach.growth is not None:
        levee = scenario["levee"].geometry if "levee" in scenario else None
        surge = None if window is None else window["surge_height"]
        times = breach.development_time  # SI: float (s) or DataArray along development_time
        if times is None:
            times = [f"{h} h" for h in (0.5, 1, 2, 4, 8)]
        elif not isinstance(times, xr.DataArray):
            times = [f"{times} s"]
        growth = breach_length(breach.growth, times, surge_height=_scalar_or_da(surge), levee=levee,
                               max_length=breach.max_length)
        if surge is not None:
            max_len = max_breach_length("all", _scalar_or_da(surge))
    return ScenarioResult(scenario.name, scenario.description, window, growth, max_len)


def model_problem() -> list[ScenarioResult]:
    """The report's Table 2.5 model problem: hurricane-borne and riverine floods (packaged TOML files)."""
    out = []
    for name in MODEL_PROBLEM_FILES:
        with resources.as_file(resources.files("breachflow.data").joinpath(name)) as path:
            out.append(run_scenario(path))
    return out


def model_problem_paths() -> list[Path]:
    return [Path(str(resources.files("breachflow.data").joinpath(n))) for n in MODEL_PROBLEM_FILES]


def typical_breach_growth(scene: BreachScene | None = None, hours=(0.5, 1.0, 2.0, 4.0, 8.0)):
    """Breach growth of every equation for the report's typical breach (docs/theory.md, *Breach growth*), the maximum lengths
    (2.9–2.11), and the development time each equation needs to reach the scene's breach length.

    Returns ``(growth, max_length, time_to_length)``: DataArrays over ``equation`` (and ``development_time``).
    """
    scene = scene or typical_breach()
    h_w = f"{scene.surge_height} m"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)  # Pugh's applicability is reported, not warned, here
        growth = breach_length("all", [f"{h} h" for h in hours], surge_height=h_w, levee=scene.levee)
        fine_hours = np.linspace(0.0, 72.0, 14401)
        fine = breach_length("all", xr.DataArray(fine_hours, dims="development_time", attrs={"units": "h"}),
                             surge_height=h_w, levee=scene.levee)
    target = scene.breach.length
    times = []
    for eq in fine["equation"].values:
        curve = fine.sel(equation=eq).values
        idx = np.flatnonzero(curve >= target)
        if idx.size == 0:
            times.append(np.nan)
        else:
            i = int(idx[0])
            t = fine_hours[i] if i == 0 else np.interp(target, curve[i - 1:i + 1], fine_hours[i - 1:i + 1])
            times.append(t * 3600.0)
    time_to = xr.DataArray(np.asarray(times), dims="equation", coords={"equation": fine["equation"].values},
                           name="time_to_breach_length",
                           attrs={"units": "s", "display_units": "h", "target_length_m": target,
                                  "long_name": f"development time to reach B = {target:g} m (NaN: not within 72 h)"})
    max_len = max_breach_length("all", h_w)
    return growth, max_len, time_to


def _scalar_or_da(v):
    if isinstance(v, xr.DataArray) and v.ndim == 0:
        return f"{float(v)} m"
    return v
