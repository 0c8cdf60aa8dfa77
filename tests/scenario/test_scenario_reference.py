"""The scenario-file reference (data_schemas/scenario.json, docs/scenario_reference.md) is generated from the
section parsers: regenerating gives the committed files, the shipped scenarios validate, and the schema
refuses what the parser refuses."""
import json
import tomllib
from pathlib import Path

import jsonschema
import pytest

from breachflow.errors import BreachflowError
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.reference import MARKDOWN_PATH, SCHEMA_PATH, render

ROOT = Path(__file__).resolve().parents[2]
# the embedded scenarios and the shipped example scenario of the report's typical breach (README)
SHIPPED = sorted((ROOT / "src" / "breachflow" / "data").glob("*.toml")) + [ROOT / "examples" / "typical_breach.toml"]


@pytest.fixture(scope="module")
def schema():
    return json.loads(SCHEMA_PATH.read_text())


def test_regenerating_the_reference_gives_the_committed_files():
    js, md = render()
    assert SCHEMA_PATH.read_text() == js, "run: python -m breachflow.scenario.reference"
    assert MARKDOWN_PATH.read_text() == md, "run: python -m breachflow.scenario.reference"


def test_the_schema_is_a_valid_json_schema_covering_every_section(schema):
    jsonschema.Draft202012Validator.check_schema(schema)
    for name in ("scenario", "site", "flood", "polder", "breach", "levee", "wind", "hydro", "dem", "fluid",
                 "placement", "criteria", "closure", "ensemble"):
        assert name in schema["properties"], name
        assert schema["properties"][name]["properties"], name
    # units and defaults are there: a quantity names its kind and SI unit, defaults come from the code
    hydro = schema["properties"]["hydro"]["properties"]
    assert hydro["resolution"]["x-kind"] == "length" and hydro["resolution"]["x-si-unit"] == "m"
    assert hydro["resolution"]["default"] == "1 m" and hydro["t_max_initial"]["default"] == "300 s"
    assert schema["properties"]["criteria"]["properties"]["max_speed"]["x-kind"] == "speed"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_shipped_scenarios_validate(schema, path):
    data = tomllib.loads(path.read_text())
    jsonschema.validate(data, schema)
    parse_scenario(path.read_text(), path)  # and the parser agrees


def _toml_value(value) -> str:
    """A value as TOML text: tables inline, lists and scalars as JSON (which TOML reads alike)."""
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return json.dumps(value)


@pytest.mark.parametrize("section, key, value", [
    ("hydro", "resolutoin", "1 m"),     # a typo of a key
    ("dem", "kn", {"a": 1}),             # a table where a value belongs
    ("closure", "seed", "one"),          # a string where an integer belongs
    ("placement", "positions", "spiral"),
    ("criteria", "mode", "most"),
])
def test_the_schema_refuses_what_the_parser_refuses(schema, section, key, value):
    base = tomllib.loads((ROOT / "src" / "breachflow" / "data" / "closure_default.toml").read_text())
    base[section][key] = value
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(base, schema)
    toml = "\n".join(f"[{s}]\n" + "\n".join(f"{k} = {_toml_value(v)}" for k, v in t.items()) for s, t in base.items())
    if not isinstance(value, dict):
        with pytest.raises(BreachflowError):
            parse_scenario(toml)


def test_an_unknown_section_is_refused(schema):
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"scenario": {"name": "x"}, "hydrology": {}}, schema)
