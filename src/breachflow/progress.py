"""One progress display for everything that takes more than a few seconds.

On a terminal it is a rich progress bar (a spinner when the total is unknown); piped, redirected or
logged — where a bar would print nothing until the end — it prints a plain line when the work starts,
then at most one line every :data:`INTERVAL` seconds (what is done, of what total, the elapsed time),
and a last line when it ends. ``quiet`` (``breachflow -q``) prints nothing. ::

    with Progress("settling", total=n, console=con) as p:
        for i in range(n):
            ...
            p.update(completed=i + 1, note="clift_gauvin")

    with Progress("first solve (open breach)", console=con):   # unknown total: a heartbeat
        solve()
"""
from __future__ import annotations

import threading
import time

#: seconds between two progress lines when the output is not a terminal
INTERVAL = 10.0


def _is_terminal(console) -> bool:
    return bool(getattr(console, "is_terminal", False))


class Progress:
    """Context manager: a bar on a terminal, periodic lines otherwise (see the module docstring).

    *label*: what is running; *total*: the amount of work (None: unknown, a heartbeat); *unit*: its unit
    in the lines (``"s"``, ``"members"``); *quiet*: print nothing; *interval*: seconds between lines
    when not on a terminal (also the heartbeat's period)."""

    def __init__(self, label: str, *, total: float | None = None, console=None, unit: str = "",
                 quiet: bool = False, interval: float = INTERVAL, terminal: bool | None = None):
        if console is None:
            from rich.console import Console

            console = Console(stderr=True)
        self.label, self.total, self.console, self.unit = label, total, console, unit
        self.quiet, self.interval = quiet, interval
        self.terminal = _is_terminal(console) if terminal is None else terminal
        self.completed = 0.0
        self.note = ""
        self._t0 = self._last = 0.0
        self._bar = self._task = None
        self._stop = threading.Event()
        self._thread = None
        self._lock = threading.Lock()
        self.lines: list[str] = []  #: the lines printed (not on a terminal)
        self._closed = False

    # ------------------------------------------------------------------ display
    def _line(self, final: bool = False) -> str:
        el = time.perf_counter() - self._t0
        done = ""
        if self.total:
            done = f" {self.completed:.6g}/{self.total:.6g}{(' ' + self.unit) if self.unit else ''}"
        elif self.completed:
            done = f" {self.completed:.6g}{(' ' + self.unit) if self.unit else ''}"
        note = f" {self.note}" if self.note else ""
        state = "done" if final else "running"
        return f"{self.label}: {state}{done}{note} ({el:.0f} s)"

    def _print(self, text: str) -> None:
        self.lines.append(text)
        self.console.print(text, highlight=False, markup=False)

    def _heartbeat(self) -> None:
        while not self._stop.wait(self.interval):
            with self._lock:
                self._print(self._line())
                self._last = time.perf_counter()

    def __enter__(self) -> "Progress":
        self._t0 = self._last = time.perf_counter()
        if self.quiet:
            return self
        if self.terminal:
            from rich.progress import BarColumn, Progress as Bar, SpinnerColumn, TextColumn, TimeElapsedColumn

            cols = [SpinnerColumn(), TextColumn(self.label)]
            if self.total:
                cols += [BarColumn(bar_width=24), TextColumn("{task.completed:.6g}/{task.total:.6g} " + self.unit)]
            cols += [TextColumn("{task.fields[note]}"), TimeElapsedColumn()]
            self._bar = Bar(*cols, console=self.console, transient=True)
            self._bar.start()
            self._task = self._bar.add_task(self.label, total=self.total, note="")
        else:
            self._print(f"{self.label}: started")
            self._thread = threading.Thread(target=self._heartbeat, name="progress", daemon=True)
            self._thread.start()
        return self

    def update(self, completed: float | None = None, *, advance: float = 0.0, total: float | None = None,
               note: str | None = None) -> None:
        """Record progress: *completed* so far (or *advance* by), a new *total*, a short *note*."""
        with self._lock:
            if total is not None:
                self.total = total
            self.completed = float(completed) if completed is not None else self.completed + advance
            if note is not None:
                self.note = note
            if self.quiet:
                return
            if self._bar is not None:
                self._bar.update(self._task, completed=self.completed, total=self.total, note=self.note)
            elif time.perf_counter() - self._last >= self.interval:
                self._print(self._line())
                self._last = time.perf_counter()

    def __exit__(self, *exc) -> bool:
        if self._closed:  # idempotent: a caller may end it early (e.g. when the first result arrives)
            return False
        self._closed = True
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._bar is not None:
            self._bar.stop()
        elif not self.quiet and exc[0] is None:
            self._print(self._line(final=True))
        return False
