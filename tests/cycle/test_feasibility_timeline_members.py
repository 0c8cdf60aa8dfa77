"""The feasibility-in-time pipeline's members on a scenario file (the typical breach): method, start, the
strategy a method can work, the cycle cap and the coarser grid land in a scenario that parses."""
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "pipelines"))


@pytest.mark.parametrize("method, positions", [("split_barge", "vertical"), ("end_dumping", "horizontal")])
def test_members_on_the_typical_breach(method, positions):
    from closure_feasibility_timeline import member_text

    from breachflow.cycle.delivery import delivery_method
    from breachflow.scenario.config import parse_scenario

    text = member_text(method, 24.0, max_cycles=30, scenario=(ROOT / "examples" / "typical_breach.toml").read_text(),
                       resolution=8.0)
    d = tomllib.loads(text)
    assert d["closure"]["method"] == method and d["closure"]["start"] == "24 h"
    assert d["placement"]["positions"] == positions and positions in delivery_method(method).positions
    assert d["hydro"]["resolution"] == "8 m" and d["criteria"]["max_cycles"] == 30
    assert d["polder"]["area"] == "4900 ha"  # the rest from the file
    parse_scenario(text)
