"""``tasks.py test`` says what it does about the CF/GDAL check tools: it names the Debian packages it installs
with apt-get (as root), and where it cannot install them it says so and that the CF/GDAL tests will skip."""
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def tasks(monkeypatch):
    spec = importlib.util.spec_from_file_location("breachflow_tasks_under_test", ROOT / "tasks.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    calls = []

    def fake_run(cmd, *a, **k):  # never really apt-get or pip anything
        calls.append(list(cmd))
        return subprocess.CompletedProcess(cmd, 0)

    monkeypatch.setattr(mod.subprocess, "run", fake_run)
    monkeypatch.setattr(mod, "CHECK_DEBS", {"gdal-bin": lambda: None, "libudunits2-0": lambda: "libudunits2.so.0"})
    return mod, calls


def test_not_root_says_what_is_missing_and_installs_nothing(tasks, monkeypatch, capsys):
    mod, calls = tasks
    monkeypatch.setattr(mod.os, "geteuid", lambda: 1000, raising=False)
    mod.ensure_check_tools()
    out = capsys.readouterr().out
    assert "gdal-bin" in out and "not installing" in out and "skip" in out and "libudunits2-0" not in out
    assert not any("apt-get" in c[0] for c in calls)


def test_root_announces_the_apt_get_install(tasks, monkeypatch, capsys):
    mod, calls = tasks
    monkeypatch.setattr(mod.os, "geteuid", lambda: 0, raising=False)
    monkeypatch.setattr(mod.shutil, "which", lambda name: f"/usr/bin/{name}")
    mod.ensure_check_tools()
    out = capsys.readouterr().out
    assert "installing the Debian packages gdal-bin with apt-get" in out
    apt = [c for c in calls if c[0] == "apt-get"]
    assert apt and apt[-1][-1] == "gdal-bin"
