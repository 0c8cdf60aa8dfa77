"""Exceptions and warnings raised by breachflow.

Every error a user can trigger with bad input derives from :class:`BreachflowError` and says *what* was
wrong *where*: the parameter, file, line or variable concerned.
"""
from __future__ import annotations


class BreachflowError(Exception):
    """Base class of every breachflow error."""


class InputError(BreachflowError, ValueError):
    """A parameter or configuration value is invalid (impossible value, NaN, unknown key...)."""


class UnitError(InputError):
    """A quantity has the wrong physical dimension or an unparsable unit."""


class ParseError(BreachflowError, ValueError):
    """A file could not be parsed; carries the file name and 1-based line number.

    >>> raise ParseError("bad token 'x'", path="mesh.3dm", line=12)
    Traceback (most recent call last):
    ...
    breachflow.errors.ParseError: mesh.3dm:12: bad token 'x'
    """

    def __init__(self, message: str, *, path=None, line: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = message
        where = self.path or "<input>"
        if line is not None:
            where = f"{where}:{line}"
        super().__init__(f"{where}: {message}")


class ImplausibleValueError(InputError):
    """A value read from a file is physically implausible (usually a unit mix-up); names the file and line.

    ``path`` and ``line`` (1-based) locate the value in the source file when the reader knows them.
    """

    def __init__(self, message: str, *, path=None, line: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = message
        super().__init__(message)


class SchemaError(BreachflowError, ValueError):
    """A Dataset does not satisfy its schema in ``data_schemas/``."""


class DiskFullError(BreachflowError, OSError):
    """The disk (or quota) filled while writing *path*; nothing half-written is left behind."""

    def __init__(self, path, detail: str = ""):
        self.path = str(path)
        msg = f"no space left on device writing {self.path}"
        super().__init__(msg + (f" ({detail})" if detail else ""))


class PhysicsError(BreachflowError, RuntimeError):
    """A simulation reached a non-physical state (NaN, negative depth, unstable time step...)."""


class BreachflowWarning(UserWarning):
    """Warnings about suspicious but usable input (e.g. implausible field values)."""
