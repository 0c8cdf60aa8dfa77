"""What every subcommand shares: the console (quiet / verbose, no wrapping when piped, a copy into a
run's ``run.log``), warnings shown on it, and the one output-flag spelling ``--out/-o``.

``console()`` returns the program's :class:`UIConsole`. On a terminal it wraps at the terminal's width;
piped or redirected (``breachflow run > log.txt``) it does not wrap at all (rich would otherwise assume
80 columns and break table cells and progress lines mid-field). ``--quiet`` keeps warnings and errors
only; ``--verbose`` adds detail lines and full tracebacks. :meth:`UIConsole.attach_log` appends
everything printed so far, and from then on every line, to a log file (no colours).
"""
from __future__ import annotations

import io
import os
import sys
import warnings
from pathlib import Path

from rich.console import Console

#: width used when the output is not a terminal: long enough never to wrap a line or a table row
PIPE_WIDTH = 4096

QUIET, NORMAL, VERBOSE = -1, 0, 1
_state = {"level": NORMAL, "console": None, "err": None}


def _width(stream) -> int | None:
    """None on a terminal (rich asks the terminal), else ``$COLUMNS`` when set, else :data:`PIPE_WIDTH`."""
    try:
        if stream.isatty():
            return None
    except (AttributeError, ValueError):
        pass
    cols = os.environ.get("COLUMNS", "")
    return int(cols) if cols.isdigit() and int(cols) > 0 else PIPE_WIDTH


#: width of ``--help`` when piped or redirected and ``$COLUMNS`` is not set: rich would assume 80 columns
#: and squeeze each option's description into a narrow column of the help panels
PIPE_HELP_WIDTH = 120


def help_width() -> int | None:
    """Width of ``--help`` output: None on a terminal (rich asks it), else ``$COLUMNS`` when set, else
    :data:`PIPE_HELP_WIDTH` (help panels are boxes as wide as the console, so not :data:`PIPE_WIDTH`)."""
    w = _width(sys.stdout)
    return None if w is None else (PIPE_HELP_WIDTH if w == PIPE_WIDTH else w)


class UIConsole(Console):
    """A rich Console that honours the verbosity level and copies what it prints into a log file."""

    def __init__(self, *, stderr: bool = False, **kw):
        stream = sys.stderr if stderr else sys.stdout
        kw.setdefault("width", _width(stream))
        super().__init__(stderr=stderr, **kw)
        self._logbuf = io.StringIO()
        self._log_file = None
        self._log = Console(file=self._logbuf, width=PIPE_WIDTH, color_system=None, force_terminal=False,
                            highlight=False, emoji=False, soft_wrap=True)

    def print(self, *objects, level: int = NORMAL, **kw):  # noqa: A003 - rich's name
        """Print at *level* (``NORMAL``; ``VERBOSE`` lines only with ``--verbose``; ``QUIET`` lines
        even with ``--quiet``); the log gets every line whatever the level."""
        if level <= _state["level"]:
            super().print(*objects, **kw)
        self._log.print(*objects, **{k: v for k, v in kw.items() if k in ("end", "sep", "markup", "highlight")})
        self._flush_log()

    def attach_log(self, path) -> Path:
        """Append what was printed so far and every later line to *path* (e.g. ``RUN/run.log``)."""
        path = Path(path)
        self._log_file = open(path, "a", encoding="utf-8")
        self._flush_log()
        return path

    def detach_log(self) -> None:
        if self._log_file is not None:
            self._flush_log()
            self._log_file.close()
            self._log_file = None

    def _flush_log(self) -> None:
        if self._log_file is None:
            return
        text = self._logbuf.getvalue()
        self._logbuf.seek(0)
        self._logbuf.truncate()
        if text:
            try:
                self._log_file.write(text)
                self._log_file.flush()
            except OSError:  # a full disk must not turn a log line into the error the user sees
                pass


def set_level(level: int) -> None:
    _state["level"] = level


def level() -> int:
    return _state["level"]


def console() -> UIConsole:
    """The program's stdout console (made on first use, so tests that capture stdout get theirs)."""
    con = _state["console"]
    if con is None or con.file is not _stream(con):
        con = _state["console"] = UIConsole()
    return con


def err_console() -> UIConsole:
    con = _state["err"]
    if con is None or con.file is not _stream(con):
        con = _state["err"] = UIConsole(stderr=True)
    return con


def _stream(con):
    return sys.stderr if con.stderr else sys.stdout


def reset() -> None:
    """Forget the consoles and the level (each CLI invocation starts afresh)."""
    for key in ("console", "err"):
        if _state[key] is not None:
            _state[key].detach_log()
        _state[key] = None
    _state["level"] = NORMAL


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` of the program: one line on stderr, and into the run log."""
    from rich.markup import escape

    text = f"[yellow]warning:[/] {escape(str(message))}"
    if level() >= VERBOSE:
        text += f" [dim]({category.__name__}, {escape(str(filename))}:{lineno})[/]"
    err_console().print(text, level=QUIET, highlight=False)
    con = console()
    if con._log_file is not None:  # the stdout console's log is the run's log
        con._log.print(f"warning: {message}")
        con._flush_log()


def install_warning_hook() -> None:
    warnings.showwarning = show_warning


def pick_out(out: Path | None, output: Path | None, flag: str = "--out") -> Path | None:
    """The one output path of a command: ``--out/-o``, or the old spelling ``--output`` (kept hidden so
    existing scripts keep working); both given and different is an error naming the flags."""
    import typer

    if out is not None and output is not None and Path(out) != Path(output):
        raise typer.BadParameter(f"give {flag} once (--output is its old spelling), got {out} and {output}")
    return out if out is not None else output


def flags_of(names) -> dict:
    """``{"surge_height": "--surge-height", ...}`` for parameter *names*."""
    return {n: "--" + n.replace("_", "-") for n in names}


def fmt(value: float, unit: str = "", digits: int = 4) -> str:
    """A float for people: *digits* significant digits, no binary noise (``3.048 m``, not
    ``3.0479999999999996 m``)."""
    s = f"{value:.{digits}g}"
    return f"{s} {unit}" if unit else s


#: Python keyword spellings in library messages -> the CLI flag that sets the same thing
_FLAG_PATTERNS = [
    (r"\bunits='(\w+)' or units='(\w+)'", r"--units \1 or --units \2"),
    (r"\bunits='(\w+)' or '(\w+)'", r"--units \1 or --units \2"),
    (r"\bvelocity_direction=<", "--velocity-direction <"),
    (r"\bvelocity_direction\b", "--velocity-direction"),
    (r"\broles=\{'([^']+)': ([^}]*)\}", r"--role \1=ROLE (ROLE: \2)"),
    (r"\bbed='<", "--bed '<"),
    (r"\bformat= one of", "--format, one of"),
    (r"\btime_units\b", "--time-units"),
    (r"\bunits=", "--units "),
]


def cli_flags(exc: BaseException, names: dict | None = None) -> BaseException:
    """Rewrite the message of breachflow error *exc* in place so that it names CLI flags
    (``--units m``) instead of the Python keyword arguments the library speaks of; *names* maps further
    parameter names to their flags (``{"breach_discharge": "--discharge"}``). Returns *exc*."""
    import re

    if exc.args and isinstance(exc.args[0], str):
        msg = exc.args[0]
        for pat, rep in _FLAG_PATTERNS:
            msg = re.sub(pat, rep, msg)
        for name, flag in (names or {}).items():
            msg = re.sub(rf"(?<![-\w]){re.escape(name)}\b", flag, msg)
        exc.args = (msg, *exc.args[1:])
    return exc
