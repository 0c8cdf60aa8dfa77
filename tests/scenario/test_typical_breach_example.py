"""examples/typical_breach.toml's SWE tolerance is the one its evidence was measured for: the tolerance the
file sets is the one the performance page (docs/performance.md) says it ships, and a row of the file's own
evidence table (``bench closure --tolerances ... --seeds ...``). Changing the tolerance without re-measuring
and re-documenting the closure answer fails here."""
import re
from pathlib import Path

from breachflow.scenario.config import parse_scenario
from breachflow.units import to_si

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "typical_breach.toml"


def _shipped_tolerance() -> tuple[str, float]:
    text = EXAMPLE.read_text(encoding="utf-8")
    raw = re.search(r'^tolerance = "([^"]+)"', text, flags=re.M)
    assert raw, f"{EXAMPLE}: no [hydro] tolerance line"
    parse_scenario(text, EXAMPLE)  # the file as `breachflow run` reads it
    return raw[1], float(to_si(raw[1], name="tolerance", kind="1/s"))


def test_the_performance_page_names_the_tolerance_the_example_ships():
    raw, si = _shipped_tolerance()
    readme = (ROOT / "docs" / "performance.md").read_text(encoding="utf-8")
    assert f'`examples/typical_breach.toml` ships\n`tolerance = "{raw}"`' in readme or \
        f'`examples/typical_breach.toml` ships `tolerance = "{raw}"`' in readme
    # the page's evidence table marks the shipped row, at the value the parser reads
    rows = [ln for ln in readme.splitlines() if ln.startswith("| ") and "(shipped)" in ln]
    assert len(rows) == 1 and float(rows[0].split()[1]) == si


def test_the_example_comment_tabulates_the_shipped_tolerance():
    raw, si = _shipped_tolerance()
    text = EXAMPLE.read_text(encoding="utf-8")
    rows = [float(m[1]) for m in re.finditer(r"^#\s+([0-9.]+e-[0-9]+)\s+.*\d+ of \d+", text, flags=re.M)]
    assert len(rows) >= 3 and si in rows  # at least three tolerances measured, the shipped one among them
