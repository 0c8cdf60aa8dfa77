"""The package's layering is a contract (``[tool.importlinter]`` in pyproject.toml, docs/architecture.md):
each package imports only from the layers below it, the discrete elements and the fluid forces do not
import each other, and the modules of one package do not import each other in a loop. import-linter
builds the import graph of the sources (imports inside functions count too) and checks the contracts."""
from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]

importlinter_cli = pytest.importorskip("importlinter.cli", reason="import-linter is in the test extra")
grimp = pytest.importorskip("grimp")


def test_import_contracts_hold(capsys):
    code = importlinter_cli.lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True)
    assert code == 0, capsys.readouterr().out


def _contract(kind: str):
    from importlinter.contracts.acyclic_siblings import AcyclicSiblingsContract
    from importlinter.contracts.independence import IndependenceContract
    from importlinter.contracts.layers import LayersContract

    cls = {"layers": LayersContract, "independence": IndependenceContract,
           "acyclic_siblings": AcyclicSiblingsContract}[kind]
    (opts,) = [c for c in CONFIG["contracts"] if c["type"] == kind]
    opts = {k: v for k, v in opts.items() if k not in ("name", "type")}
    return cls(name=kind, session_options={"root_packages": ["breachflow"]}, contract_options=opts)


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph("breachflow", exclude_type_checking_imports=True, cache_dir=None)


@pytest.mark.parametrize("kind, importer, imported", [
    ("layers", "breachflow.dem.state", "breachflow.cycle.driver"),          # a physics package imports the cycle
    ("layers", "breachflow.cycle.driver", "breachflow.ensemble.runners"),   # the cycle imports the ensembles
    ("layers", "breachflow.io.adh", "breachflow.swe.solver"),               # a reader imports the solver
    ("independence", "breachflow.dem.integrators", "breachflow.fluid.freeflight"),
    ("independence", "breachflow.fluid.forces", "breachflow.dem.state"),
    ("acyclic_siblings", "breachflow.io.sms_binary", "breachflow.io.sms_dat"),  # sms_dat imports sms_binary
])
def test_contracts_catch_a_violation(graph, kind, importer, imported):
    """Each contract is kept by the package's graph and broken by one added import against it, so the
    check above can fail."""
    contract = _contract(kind)
    assert contract.check(copy.deepcopy(graph), verbose=False).kept  # a check may drop ignored imports
    g = copy.deepcopy(graph)
    g.add_import(importer=importer, imported=imported, line_number=1, line_contents=f"import {imported}")
    assert not contract.check(g, verbose=False).kept
