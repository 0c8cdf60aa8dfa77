"""Scenario inputs that make no physical sense are refused or warned before anything runs."""
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.main import default_scenario_text
from breachflow.cycle.sanity import outcome_warnings
from breachflow.errors import InputError
from breachflow.scenario.config import parse_scenario


def _setup(placement: str):
    return closure_setup(parse_scenario("[placement]\n" + placement))


def test_default_scenario_passes_without_warnings():
    assert closure_setup(parse_scenario(default_scenario_text())).warnings == []


@pytest.mark.parametrize("placement,match", [
    ('density = "990 kg/m^3"', "not heavier than water"),
    ('density = ["900 kg/m^3", "2650 kg/m^3"]', "not heavier than water"),
    ('diameter = "13 m"', "wider than the breach"),
    ('positions = "zone"\nzone = ["-5 m", "5 m", "-500 m", "5 m"]', "outside the domain"),
    ('positions = "list"\npoints = [["0 m", "0 m"], ["900 m", "0 m"]]', "outside the domain"),
    ('start = ["-5 m", "0 m"]\nstop = ["5 m", "1000 m"]', "outside the domain"),
])
def test_impossible_placements_are_refused(placement, match):
    with pytest.raises(InputError, match=match):
        _setup(placement)


def test_suspicious_placements_are_warned():
    w = _setup('diameter = "2 m"\nstart = ["0 m", "0 m"]\nstop = ["1 m", "0 m"]').warnings
    assert any("shorter than the masses" in x for x in w)
    w = _setup('diameter = "2 m"\nbatch = 8\nstart = ["-5 m", "0 m"]\nstop = ["5 m", "0 m"]').warnings
    assert any("does not fit side by side" in x for x in w)
    assert _setup('diameter = "2 m"\nbatch = 5\nstart = ["-5 m", "0 m"]\nstop = ["5 m", "0 m"]').warnings == []


def test_outcome_warnings_count():
    w = outcome_warnings(3, 2, 30, 0.5, 1.7)
    assert "3 of 30 masses left the domain" in w[0]
    assert "2 of 30 masses were still moving" in w[1]
    assert "smaller than Izbash" in w[2]
    assert outcome_warnings(0, 0, 30, 2.0, 1.7) == []


def test_summary_shows_warnings_verbatim():
    """A warning starting with its scenario section, ``[placement] ...``, is printed as written (rich would
    otherwise take ``[placement]`` for a markup tag and drop it)."""
    from rich.console import Console

    from breachflow.cli.run import summary_table

    w = _setup('diameter = "2 m"\nbatch = 8\nstart = ["-5 m", "0 m"]\nstop = ["5 m", "0 m"]').warnings
    con = Console(width=400, record=True, file=open("/dev/null", "w"))
    con.print(summary_table([("warning", w[0]), ("[bold]", "[/x]")]))
    text = con.export_text()
    assert "[placement] a batch of 8 masses" in text
    assert "[bold]" in text and "[/x]" in text
