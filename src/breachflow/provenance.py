"""Provenance of every file breachflow writes: package version, git commit, the command that wrote it.

:func:`attrs` is the one place these attributes are made; every writer (cycle files, trajectories,
archives, snapshots, ensemble results, the run manifest) calls it, usually through :func:`stamp`, which
also prepends a line to the CF ``history`` attribute (CF §2.6.2: an audit trail, newest first)::

    breachflow_version     "0.2.0"
    breachflow_git_commit  the commit id, "+dirty" with local changes (only when the package is imported from a git checkout)
    breachflow_command     "breachflow run my.toml --out runs/mine" (the Python command line otherwise)
    history                "2026-11-23T16:20:00+00:00: breachflow run my.toml --out runs/mine\\n<older lines>"
"""
from __future__ import annotations

import contextlib
import contextvars
import shlex
import subprocess
import sys
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path

_COMMAND: str | None = None
#: a command set for the current thread / task only (ensemble members run on workers: their files record
#: the ``breachflow ensemble ...`` command that planned them, not the worker process's command line)
_TASK_COMMAND: contextvars.ContextVar[str | None] = contextvars.ContextVar("breachflow_command", default=None)


def set_command(argv: list[str] | None) -> None:
    """Record the command line the program was started with (the CLI calls this; None forgets it)."""
    global _COMMAND
    _COMMAND = None if argv is None else shlex.join(["breachflow", *argv])


@contextlib.contextmanager
def using_command(cmd: str | None):
    """Within this block (this thread only), files record *cmd* as the command that wrote them."""
    token = _TASK_COMMAND.set(cmd)
    try:
        yield
    finally:
        _TASK_COMMAND.reset(token)


def command() -> str:
    """The command of the current task (:func:`using_command`), else the recorded CLI command, else the
    Python command line (``python script.py args``)."""
    task = _TASK_COMMAND.get()
    if task is not None:
        return task
    if _COMMAND is not None:
        return _COMMAND
    argv = list(sys.argv) or ["python"]
    return shlex.join([Path(sys.executable).name, *argv]) if argv[0] else Path(sys.executable).name


def version() -> str:
    from . import __version__

    return __version__


@lru_cache(maxsize=1)
def git_commit() -> str | None:
    """``git rev-parse HEAD`` of the checkout the package is imported from; None when it is not in one
    (an installed wheel), git is missing or fails. A checkout with uncommitted changes gets ``+dirty``."""
    here = Path(__file__).resolve().parent
    try:
        top = subprocess.run(["git", "-C", str(here), "rev-parse", "--show-toplevel"], capture_output=True,
                             text=True, timeout=5)
        if top.returncode or not (Path(top.stdout.strip()) / "src" / "breachflow").is_dir():
            return None  # not breachflow's own checkout (e.g. a venv inside some other repository)
        head = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=5)
        if head.returncode:
            return None
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no", "--", "."],
                               capture_output=True, text=True, timeout=10)
        return head.stdout.strip() + ("+dirty" if dirty.returncode == 0 and dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def attrs() -> dict:
    """Provenance attributes: ``breachflow_version``, ``breachflow_git_commit`` (when known) and
    ``breachflow_command``."""
    out = {"breachflow_version": version()}
    commit = git_commit()
    if commit:
        out["breachflow_git_commit"] = commit
    out["breachflow_command"] = command()
    return out


def history_line() -> str:
    return f"{datetime.now(timezone.utc).isoformat(timespec='seconds')}: {command()}"


def stamp(ds):
    """A shallow copy of Dataset *ds* with :func:`attrs` set and this command prepended to ``history``."""
    out = ds.copy(deep=False)
    out.attrs = dict(ds.attrs)
    out.attrs.update(attrs())
    old = str(out.attrs.get("history", "") or "").strip()
    out.attrs["history"] = history_line() + ("\n" + old if old else "")
    return out

