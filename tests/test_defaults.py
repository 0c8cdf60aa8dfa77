"""Each default is defined once: the constructors, the scenario sections, the scenario schema
(data_schemas/scenario.json) and a parsed scenario that leaves the key out all take the registry's
default (or the one dataclass field that defines it)."""
import inspect
import json
from dataclasses import fields
from pathlib import Path

import pytest

from breachflow.cycle.config.dem import FluidSection
from breachflow.cycle.driver import DemSettings
from breachflow.dem.integrators import integrators
from breachflow.dem.simulation import DemSimulation
from breachflow.field.sampling import SAMPLING_METHODS, FieldSampler
from breachflow.fluid.drag import DRAG_LAWS
from breachflow.fluid.field import as_field
from breachflow.fluid.forces import FluidForces
from breachflow.fluid.profile import DEFAULT_PROFILE, velocity_profiles
from breachflow.scenario.config import BreachSection, parse_scenario
from breachflow.scenario.geometry import BreachGeometry
from breachflow.site.domain import SiteSpec

SCHEMA = json.loads((Path(__file__).resolve().parents[1] / "data_schemas" / "scenario.json").read_text())


def param_default(func, name):
    return inspect.signature(func).parameters[name].default


def field_default(cls, name):
    return {f.name: f for f in fields(cls)}[name].default


def schema_default(section, key):
    return SCHEMA["properties"][section]["properties"][key].get("default")


@pytest.mark.parametrize("registry,value,uses", [
    (velocity_profiles, "log", [(FluidForces, "velocity_profile"), (DemSettings, "velocity_profile"),
                                (FluidSection, "velocity_profile"), ("fluid", "velocity_profile")]),
    (DRAG_LAWS, "report", [(FluidForces, "drag_law"), (DemSettings, "drag_law"), (FluidSection, "drag_law"),
                           ("fluid", "drag_law")]),
    (SAMPLING_METHODS, "bilinear", [(FluidForces, "sampling"), (DemSettings, "sampling"), (FluidSection, "sampling"),
                                    (FieldSampler, "method"), (as_field, "sampling"), ("fluid", "sampling")]),
    (integrators, "predicted_verlet", [(DemSimulation, "integrator"), (DemSettings, "integrator"),
                                       ("dem", "integrator")]),
])
def test_a_choice_defaults_to_its_registry_default_everywhere(registry, value, uses):
    assert registry.default == value and value in registry
    for where, name in uses:
        if isinstance(where, str):
            got = schema_default(where, name)
        elif where in (DemSettings, FluidSection):
            got = field_default(where, name)
        else:
            got = param_default(where, name)
        assert got == registry.default, (where, name, got)
    assert DEFAULT_PROFILE is velocity_profiles.default


def test_a_scenario_without_the_keys_runs_the_registry_defaults():
    setup = parse_scenario("[dem]\n[fluid]\n")
    assert setup.fluid.velocity_profile == velocity_profiles.default
    assert setup.fluid.drag_law == DRAG_LAWS.default and setup.fluid.sampling == SAMPLING_METHODS.default
    # a model built directly sees the flow as the closure run does
    assert FluidForces(0.0).velocity_profile == velocity_profiles.default


def test_breach_geometry_defaults_are_the_geometry_class_fields():
    sec = BreachSection(length=20.0, depth=3.0)
    g = sec.geometry()
    assert g.wall_slope == field_default(BreachGeometry, "wall_slope")
    assert g.scour_depth == field_default(BreachGeometry, "scour_depth")
    assert BreachGeometry(20.0, 3.0) == g
    # a given value still wins
    assert BreachSection(length=20.0, depth=3.0, wall_slope=0.0).geometry().wall_slope == 0.0


@pytest.mark.parametrize("key", ["breach_wall_slope", "manning_n", "absorbing"])
def test_terrain_site_defaults_are_the_site_spec_fields(key):
    assert schema_default("site", key) == field_default(SiteSpec, key)
