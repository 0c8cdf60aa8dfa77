"""One plug-in pattern (docs/architecture.md): every choice is a :class:`~breachflow.registry.Registry`,
looked up with ``get`` / ``create``, and every built-in is declared as an entry point in pyproject.toml
(so a registry finds a built-in that lives in a layer above it the way it finds a third-party one)."""
from __future__ import annotations

import importlib
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from breachflow.errors import InputError
from breachflow.registry import Registry

ROOT = Path(__file__).resolve().parents[1]
EPS = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]

# every registry of the package: (module, attribute)
REGISTRIES = [
    ("breachflow.io", "READERS"), ("breachflow.hydro.solvers", "solvers"),
    ("breachflow.hydro.far_field", "far_fields"), ("breachflow.field.sampling.methods", "SAMPLING_METHODS"),
    ("breachflow.fluid.drag", "DRAG_LAWS"), ("breachflow.fluid.profile", "velocity_profiles"),
    ("breachflow.dem.integrators", "integrators"), ("breachflow.dem.contact_law", "contact_laws"),
    ("breachflow.dem.steploop", "step_loops"), ("breachflow.cycle.criteria", "criteria"),
    ("breachflow.cycle.rest", "REST_RULES"), ("breachflow.cycle.strategies", "placement_strategies"),
    ("breachflow.ensemble.runners", "member_runners"), ("breachflow.scenario.config", "sections"),
    ("breachflow.scenario.growth", "growth_equations"), ("breachflow.scenario.growth", "max_length_equations"),
    ("breachflow.swe.porous_laws", "POROUS_LAWS"),
]


def _load(target: str):
    module, _, attr = target.partition(":")
    obj = importlib.import_module(module)
    for part in filter(None, attr.split(".")):
        obj = getattr(obj, part)
    return obj


def _home(obj) -> str:
    """The module that defines *obj* (a class or function), or *obj*'s own name (a module)."""
    return getattr(obj, "__module__", None) or getattr(obj, "__name__", "")


@pytest.mark.parametrize("module, attr", REGISTRIES)
def test_every_builtin_is_a_declared_entry_point(module, attr):
    reg = getattr(importlib.import_module(module), attr)
    assert isinstance(reg, Registry)
    declared = EPS.get(reg.group, {})
    reg.available()  # loads the declared entry points too
    # breachflow's own (a test may have registered a stand-in of its own in this process)
    names = sorted(n for n in reg.available() if _home(reg.get(n)).startswith("breachflow."))
    assert names and set(names) == set(declared), f"{reg.group}: registered {names}, declared {sorted(declared)}"
    for name, target in declared.items():
        assert reg.get(name) is _load(target), f"{reg.group}: {name} = {target!r} is not the registered object"


def test_create_makes_an_instance_with_options_and_names_bad_ones():
    reg = Registry("test law", "breachflow.test_laws_none")

    @reg.register("scaled")
    class Scaled:
        def __init__(self, factor: float = 1.0):
            self.factor = factor

    assert reg.create("SCALED", factor=2.5).factor == 2.5
    made = Scaled(3.0)
    assert reg.create(made) is made  # an instance made by the caller is used as it is
    with pytest.raises(InputError, match="test law 'scaled': bad options"):
        reg.create("scaled", speed=1.0)
    with pytest.raises(InputError, match="unknown test law 'nope'; available: scaled"):
        reg.create("nope")
    with pytest.raises(InputError, match="is an instance"):
        reg.create(made, factor=2.0)


#: each line runs in one fresh interpreter, in order: the DEM finds the compiled loop and adaptive_free_flight
#: (both in breachflow.coupling), the ensembles the closure runner, the scenario loader the closure sections,
#: by name only (no module above them imported before the lookup)
FRESH_LOOKUPS = """
import sys
from breachflow.dem.steploop import step_loops
from breachflow.dem.integrators import integrators
from breachflow.scenario.config import sections
assert not any(m.startswith(("breachflow.coupling", "breachflow.cycle", "breachflow.ensemble")) for m in sys.modules)
assert step_loops.get("fluid_verlet").__name__ == "breachflow.coupling.steploop"
assert integrators.get("adaptive_free_flight").__module__ == "breachflow.coupling.integrators"
assert sections.get("dem").__module__ == "breachflow.cycle.config.dem"
from breachflow.ensemble.runners import member_runners
assert member_runners.get("closure").__module__ == "breachflow.ensemble.closure"
"""


def test_a_registry_finds_builtins_above_it_through_entry_points():
    out = subprocess.run([sys.executable, "-c", FRESH_LOOKUPS], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
