"""The ``[ensemble]`` table seen from the scenario loader.

A spec file is also a scenario file (its other tables are the base scenario), so
``breachflow.scenario.load_scenario("spec.toml")`` works: the loader imports this module for the
``[ensemble]`` section (an entry point of ``breachflow.scenario_sections``), which checks its keys and keeps it for
:func:`breachflow.ensemble.run`.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..scenario import register_section
from .spec import ENSEMBLE_KEYS, EnsembleSpec


@register_section("ensemble")
@dataclass
class EnsembleSection:
    """``[ensemble]``: ``runner``, ``base``, ``vary`` / ``members``, ``options``, ``seed``, ``output``,
    ``workers``, ``scheduler``, ``name``, ``description``, ``design`` (see :mod:`breachflow.ensemble.spec`)."""

    table: dict

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, ENSEMBLE_KEYS - {"vary", "options"}, subtables=("vary", "options"))
        return cls(dict(table))

    def spec(self, scenario) -> EnsembleSpec:
        """The :class:`EnsembleSpec` of the scenario file this section came from."""
        from .spec import load_spec

        return load_spec(scenario.path)
