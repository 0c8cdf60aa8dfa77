"""Scenario TOML text: dotted-key changes of a scenario (breachflow.scenario.toml)."""
import tomllib

import pytest

from breachflow.errors import InputError
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with

BASE = """
[hydro]
resolution = "2 m"
order = 1
[placement]
diameter = ["1.6 m", "2.0 m"]
start = ["-4 m", "0 m"]
"""


def test_changes_set_create_and_drop_keys():
    text = scenario_with(BASE, {"hydro.order": 2, "placement.start": None, "criteria.max_cycles": 3,
                                "ensemble.vary.x": [1, 2]})
    data = tomllib.loads(text)
    assert data["hydro"] == {"resolution": "2 m", "order": 2}
    assert data["placement"] == {"diameter": ["1.6 m", "2.0 m"]}
    assert data["criteria"] == {"max_cycles": 3}
    assert data["ensemble"]["vary"]["x"] == [1, 2]
    assert float(parse_scenario(scenario_with(BASE, {"hydro.order": 2}))["hydro"].order) == 2
    assert tomllib.loads(scenario_with(BASE, {})) == tomllib.loads(BASE)


@pytest.mark.parametrize("changes, match", [({"order": 2}, "dotted path"),
                                            ({"hydro.order.x": 1}, "'order' is not a table")])
def test_bad_changes_name_the_key(changes, match):
    with pytest.raises(InputError, match=match):
        scenario_with(BASE, changes)


def test_malformed_text_is_an_input_error():
    with pytest.raises(InputError, match="scenario text"):
        scenario_with("[hydro\n", {"hydro.order": 1})
