"""The documents and the package speak to users about the product: no references to files outside the
repository (the specification the equations were first collected in), no work sessions, branch names,
"main of ...", or commit hashes, except the one form a measurement names its version by,
"version X.Y.Z (git abc1234)"."""
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TEXT_SUFFIXES = {".md", ".rst", ".py", ".toml", ".json", ".txt", ".ipynb", ".csv", ".cfg"}

#: what may not appear (case-insensitive): the name of the rule and its pattern
FORBIDDEN = {
    "reference to SPEC.md": r"SPEC\.md|\bSPEC\s*§",
    "work session": r"\bsessions? [0-9]+\b|\bsession's\b",
    "branch name": r"\bbranch i[0-9]+|\bi[0-9]+-[a-z]+[a-z0-9]*\b",
    "'main of'": r"\bmain of\b",
    "old commit": r"\b(main|commit|than main|on main)\s+[0-9a-f]{7,40}\b",
    "commit hash": r"(?<![0-9A-Za-z_.\-/])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?![0-9A-Za-z_\-])",
}
#: the one allowed form of a hash: a measurement's version, e.g. "version 0.1.0 (git eb30102)"
ALLOWED = re.compile(r"version\s+\d+\.\d+\.\d+[^\s()]*\s+\(git\s+[0-9a-f]{7,40}\)")


def _files():
    yield ROOT / "README.md"
    yield ROOT / "CHANGELOG.md"
    for top in ("docs", "src", "examples/notebooks"):
        for p in sorted((ROOT / top).rglob("*")):
            if (p.is_file() and p.suffix in TEXT_SUFFIXES and "_build" not in p.parts
                    and ".egg-info" not in p.parent.name and "__pycache__" not in p.parts):
                yield p


def violations(text: str) -> list[tuple[int, str, str]]:
    """(line number, rule, the line) of every forbidden phrase in *text*."""
    found = []
    # the allowed version form may wrap over lines: blank it out, keeping the line breaks
    cleaned = ALLOWED.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)
    for i, (line, clean) in enumerate(zip(text.splitlines(), cleaned.splitlines()), 1):
        for rule, pattern in FORBIDDEN.items():
            flags = 0 if rule == "commit hash" else re.IGNORECASE
            if re.search(pattern, clean, flags):
                found.append((i, rule, line.strip()[:160]))
    return found


def _text(path: Path) -> str:
    """A file's text; of a notebook, its cells' sources (the cell ids are random hex, not commits)."""
    text = path.read_text(encoding="utf-8", errors="replace")
    if path.suffix == ".ipynb":
        return "\n".join("".join(c.get("source", "")) for c in json.loads(text)["cells"])
    return text


def test_no_document_or_source_speaks_of_sessions_branches_commits_or_outside_files():
    bad = []
    for p in _files():
        if p.exists():
            for i, rule, line in violations(_text(p)):
                bad.append(f"{p.relative_to(ROOT)}:{i}: {rule}: {line}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("text", [
    "The equations are in ../shared/SPEC.md.",
    "closure window (SPEC §2)",
    "measured in session 9",
    "on branch i16-rebuild",
    "the i14-strategies runs",
    "main of 2026-11-24",
    "1.29 x faster than main 187b132",
    "measured on 45a69a6, idle",
    "(commit 83dc584)",
])
def test_each_forbidden_form_is_caught(text):
    assert violations(text), text


@pytest.mark.parametrize("text", [
    "2026-11-24, version 0.1.0 (git eb30102), `python3 tasks.py bench dem`",
    "measured 2026-11-24, version 0.1.0\n(git eb30102), idle",
    "session(action) records the start, resume and overwrite of a run",
    "the 0x9e3779b9 golden-ratio constant",
    "EPSG:32615, a 1000000-cell grid, 12345678 steps",
    "deadbeef",  # letters only: a word, not a hash
    "breachflow_git_commit attribute",
])
def test_allowed_forms_pass(text):
    assert not violations(text), violations(text)
