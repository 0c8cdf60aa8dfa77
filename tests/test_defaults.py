"""Each default is defined once: the constructors, the scenario sections, the scenario schema
(data_schemas/scenario.json) and a parsed scenario that leaves the key out all take the registry's
default (or the one dataclass field that defines it)."""
import inspect
import json
from dataclasses import fields
from pathlib import Path

import pytest

from breachflow.cycle.config.closure import ClosureSection
from breachflow.cycle.config.dem import FluidSection
from breachflow.cycle.driver import ClosureSetup, DemSettings
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
from breachflow.swe.porous import PorousPile
from breachflow.swe.porous_laws import POROUS_LAWS

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
    (POROUS_LAWS, "ergun", [(ClosureSection, "porous_law"), (ClosureSetup, "porous_law"),
                            ("closure", "porous_law")]),
])
def test_a_choice_defaults_to_its_registry_default_everywhere(registry, value, uses):
    assert registry.default == value and value in registry
    for where, name in uses:
        if isinstance(where, str):
            got = schema_default(where, name)
        elif where in (DemSettings, FluidSection, ClosureSection, ClosureSetup):
            got = field_default(where, name)
        else:
            got = param_default(where, name)
        assert got == registry.default, (where, name, got)
    assert DEFAULT_PROFILE is velocity_profiles.default


def test_a_pile_without_a_law_takes_the_registry_default():
    pile = PorousPile.build([[1.0]], [[0.45]], [[1.5]])
    A, B = POROUS_LAWS.create(POROUS_LAWS.default).coefficients(0.45, 1.5)
    assert (pile.A[0, 0], pile.B[0, 0]) == (A, B)
    assert pile.layer_B[0, 0, 0] == B


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


# --------------------------------------------------------------------------- the breach wall slope
SRC = Path(__file__).resolve().parents[1] / "src" / "breachflow"


def _wall_slope_defaults():
    """Every default the package's source gives a ``*wall_slope*`` name: parameter defaults, class
    fields, ``getattr(x, "...wall_slope", d)`` / ``x.get("...wall_slope", d)`` fall-backs and
    ``typer.Option(d)`` of such a parameter, as ``(file:line, name, source text of the default)``."""
    import ast

    found = []
    for path in sorted(SRC.rglob("*.py")):
        text = path.read_text()
        tree = ast.parse(text)
        where = lambda node: f"{path.relative_to(SRC)}:{node.lineno}"  # noqa: E731
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                a = node.args
                pos = a.posonlyargs + a.args
                pairs = list(zip(pos[len(pos) - len(a.defaults):], a.defaults)) + \
                    [(k, d) for k, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None]
                for arg, d in pairs:
                    if "wall_slope" in arg.arg:
                        if isinstance(d, ast.Call) and getattr(d.func, "attr", "") == "Option" and d.args:
                            d = d.args[0]  # typer.Option(default, help=...)
                        found.append((where(d), arg.arg, ast.unparse(d)))
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                if "wall_slope" in node.target.id and node.value is not None:
                    found.append((where(node), node.target.id, ast.unparse(node.value)))
            elif isinstance(node, ast.Call) and len(node.args) >= 2:
                fn = node.func
                name = fn.id if isinstance(fn, ast.Name) else getattr(fn, "attr", "")
                key = node.args[1] if name == "getattr" else node.args[0] if name == "get" else None
                fallback = node.args[2] if name == "getattr" and len(node.args) > 2 else \
                    node.args[1] if name == "get" else None
                if isinstance(key, ast.Constant) and "wall_slope" in str(key.value) and fallback is not None:
                    found.append((where(node), str(key.value), ast.unparse(fallback)))
    return found


def test_the_breach_wall_slope_has_one_default_defined_once():
    """1V:0.5H (the report's "mostly 2V:1H") is named once, DEFAULT_WALL_SLOPE; every default of a
    breach wall slope in the source is that name (or None: "not given, take the default"), never a
    number of its own. A second default (say ``wall_slope=0.0`` in a new function) fails here."""
    from breachflow.scenario.geometry import DEFAULT_WALL_SLOPE

    assert DEFAULT_WALL_SLOPE == 0.5
    found = _wall_slope_defaults()
    names = {n for _, n, _ in found}
    # the scan sees the defaults it must see (a scan that finds nothing would pass vacuously)
    assert {"wall_slope", "breach_wall_slope"} <= names, found
    assert len(found) >= 6, found
    own = [f for f in found if f[2] not in ("DEFAULT_WALL_SLOPE", "None")]
    assert own == [], f"breach wall slope defaults other than DEFAULT_WALL_SLOPE: {own}"
    defined = [ln for p in SRC.rglob("*.py") for ln in p.read_text().splitlines()
               if ln.startswith("DEFAULT_WALL_SLOPE =")]
    assert defined == ["DEFAULT_WALL_SLOPE = 0.5"]


def test_every_breach_wall_slope_default_is_the_one_value_at_run_time():
    from breachflow.cycle.timeline import Timeline
    from breachflow.scenario.discharge import weir_discharge
    from breachflow.scenario.geometry import DEFAULT_WALL_SLOPE
    from breachflow.scenario.stone import fill_volume, stone_size

    uses = [field_default(BreachGeometry, "wall_slope"), field_default(SiteSpec, "breach_wall_slope"),
            field_default(Timeline, "wall_slope"), param_default(weir_discharge, "wall_slope"),
            param_default(fill_volume, "wall_slope"), param_default(stone_size, "wall_slope"),
            schema_default("site", "breach_wall_slope")]
    assert uses == [DEFAULT_WALL_SLOPE] * len(uses)


def test_a_breach_left_without_its_wall_slope_gets_1v_0_5h_by_independent_arithmetic(tmp_path):
    """Fread's trapezoidal weir Q = C (b h^1.5 + 2.45/3.1 m h^2.5), C = 3.1 ft^0.5/s, and the fill volume
    ∫0^H (b + 2 m (H − z)) (B + 2 m_W z) dz, computed here by hand with m_W = 0.5; heads and lengths swept."""
    from breachflow.scenario.discharge import weir_discharge
    from breachflow.scenario.stone import fill_volume

    C = 3.1 * 0.3048 ** 0.5
    for h, b in ((0.3, 4.0), (2.0, 20.0), (7.6, 61.0)):
        q = C * (b * h ** 1.5 + 2.45 / 3.1 * 0.5 * h ** 2.5)
        assert weir_discharge(f"{h} m", bottom_width=f"{b} m") == pytest.approx(q, rel=1e-12)
        assert weir_discharge(f"{h} m", bottom_width=f"{b} m", wall_slope=0.0) == pytest.approx(C * b * h ** 1.5,
                                                                                               rel=1e-12)
    for B, H, crest, m in ((12.0, 3.0, 2.0, 1.5), (61.0, 7.6, 5.0, 2.0)):
        n = 20000  # midpoint rule of the integrand above
        dz = H / n
        vol = sum((crest + 2 * m * (H - (k + 0.5) * dz)) * (B + 2 * 0.5 * (k + 0.5) * dz) * dz for k in range(n))
        assert fill_volume(B, H, crest, m) == pytest.approx(vol, rel=1e-6)
    # the scenario keys: [breach] without wall_slope, a terrain [site] without breach_wall_slope
    assert BreachSection(length=20.0, depth=3.0).geometry().bottom_width == pytest.approx(20.0 - 2 * 0.5 * 3.0)
    (tmp_path / "t.tif").write_bytes(b"")
    sc = parse_scenario(f'[site]\nterrain = "{tmp_path / "t.tif"}"\nlevee_coords = [[0, 0], [10, 0]]\n'
                        'breach_at = "5 m"\nbreach_length = "4 m"\nbreach_bottom = "0 m"\nflood_level = "1 m"\n')
    assert sc["site"].spec.breach_wall_slope == 0.5
