"""Small named registries for the pluggable parts (readers, solvers, drag laws, integrators, ...).

Modelled on xarray's backend entry points: built-ins register themselves with the
:meth:`Registry.register` decorator and are declared as entry points in breachflow's own
``pyproject.toml``; third-party packages add theirs through the same entry point group
(``[project.entry-points."breachflow.drag_laws"]`` in their ``pyproject.toml``), loaded lazily
the first time a name is looked up. Every choice is made the same way: :meth:`Registry.get` for the
class, :meth:`Registry.create` for an instance with options (docs/architecture.md lists the groups).
A registry whose choice has a default holds it (:attr:`Registry.default`): the constructors, the scenario
sections and the scenario schema take the default from there, so it is defined once.
"""
from __future__ import annotations

from importlib.metadata import entry_points
from typing import Generic, TypeVar

from .errors import InputError

T = TypeVar("T")


class Registry(Generic[T]):
    """A name → class (or factory) mapping with entry-point discovery.

    >>> laws = Registry("drag law", "breachflow.drag_laws")
    >>> @laws.register("constant")
    ... class Constant: ...
    >>> laws.get("constant") is Constant
    True
    """

    def __init__(self, kind: str, group: str, default: str | None = None):
        self.kind = kind
        self.group = group
        #: the name chosen when none is given (None: the choice has no default)
        self.default = default
        self._items: dict[str, T] = {}
        self._loaded_entry_points = False

    def register(self, name: str, obj: T | None = None, *, overwrite: bool = False):
        """Register *obj* under *name*; usable as a decorator when *obj* is omitted."""

        def deco(o):
            key = name.lower()
            if key in self._items and not overwrite and self._items[key] is not o:
                raise InputError(f"{self.kind} {name!r} is already registered")
            self._items[key] = o
            return o

        return deco if obj is None else deco(obj)

    def _load_entry_points(self) -> None:
        if self._loaded_entry_points:
            return
        self._loaded_entry_points = True
        for ep in entry_points(group=self.group):
            if ep.name.lower() not in self._items:
                try:
                    self._items[ep.name.lower()] = ep.load()
                except Exception as exc:  # a broken plug-in must not break the built-ins
                    import warnings

                    warnings.warn(f"could not load {self.kind} plug-in {ep.name!r} ({ep.value}): {exc}")

    def get(self, name: str) -> T:
        """Return the entry called *name* (case-insensitive) or raise InputError listing the choices."""
        key = str(name).lower()
        if key not in self._items:
            self._load_entry_points()
        try:
            return self._items[key]
        except KeyError:
            raise InputError(
                f"unknown {self.kind} {name!r}; available: {', '.join(self.available())}"
            ) from None

    def create(self, choice, /, **options):
        """An instance of the entry called *choice* made with *options*, or *choice* itself when it is not a
        name (an instance made by the caller, *options* then must be empty); InputError for an unknown
        name or options the entry does not take."""
        if not isinstance(choice, str):
            if options:
                raise InputError(f"{self.kind} {choice!r} is an instance: options {sorted(options)} cannot apply")
            return choice
        cls = self.get(choice)
        try:
            return cls(**options)
        except TypeError as exc:
            raise InputError(f"{self.kind} {choice!r}: bad options {sorted(options)} ({exc})") from None

    def available(self) -> list[str]:
        self._load_entry_points()
        return sorted(self._items)

    def __contains__(self, name: str) -> bool:
        key = str(name).lower()
        if key not in self._items:
            self._load_entry_points()
        return key in self._items

    def __iter__(self):
        return iter(self.available())
