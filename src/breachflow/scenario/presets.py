"""Flood presets: rise and fall rates of real floods (report Tables 2.3 and 2.4; docs/theory.md, *Closure window*).

The data ship as ``breachflow/data/flood_presets.csv`` (heights in m, times in h, as tabulated). Rates are
height / time. Hurricane presets also give the peak surge at the tidal gage as a default ``h_W``; river
presets give no ``h_W`` (the gauge stage says nothing about the water height at a breach).
Generic presets name the report's model problem and Table 2.6 rates.
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources

from ..errors import InputError
from .hydrograph import _HEADER

HOUR = 3600.0


@dataclass(frozen=True)
class FloodPreset:
    """One flood: rise/fall rates (m/s), optional default surge height h_W (m), descriptive fields."""

    key: str
    kind: str
    event: str
    rise_rate: float
    fall_rate: float
    surge_height: float | None = None
    location: str = ""
    date: str = ""
    source: str = ""
    extra: dict = field(default_factory=dict)

    def describe(self) -> str:
        return (f"{self.event} ({self.location}, {self.date}): rise {self.rise_rate * 3.6e5:.3g} cm/h, "
                f"fall {self.fall_rate * 3.6e5:.3g} cm/h")


_GENERIC = [
    FloodPreset("model_hurricane", "generic", "Model problem, hurricane-borne flood", 0.4 / HOUR, 0.4 / HOUR, 2.8,
                source="report §2.4, Table 2.5"),
    FloodPreset("model_riverine", "generic", "Model problem, riverine flood", 0.06 / HOUR, 0.06 / HOUR, 2.8,
                source="report Table 2.5 (the text's 1.5/0.6 cm/h contradicts the table; docs/theory.md, *Closure window* uses the table)"),
    FloodPreset("rapid_fall", "generic", "Table 2.6 rapid fall (hurricane)", 0.30 / HOUR, 0.30 / HOUR,
                source="report Table 2.6"),
    FloodPreset("slow_fall", "generic", "Table 2.6 slow fall (riverine)", 0.02 / HOUR, 0.02 / HOUR,
                source="report Table 2.6"),
]


@lru_cache(maxsize=1)
def _load() -> dict[str, FloodPreset]:
    text = resources.files("breachflow.data").joinpath("flood_presets.csv").read_text()
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    reader = csv.reader(io.StringIO("\n".join(lines)))
    header = next(reader)
    names = [_HEADER.match(h).group(1).strip() for h in header]
    out: dict[str, FloodPreset] = {p.key: p for p in _GENERIC}
    for row in reader:
        rec = dict(zip(names, row))
        num = {k: float(v) for k, v in rec.items() if v and k not in {"key", "kind", "event", "location", "date", "note"}}
        table = "Table 2.3 (NOAA 2009)" if rec["kind"] == "hurricane" else "Table 2.4 (USGS 2009)"
        out[rec["key"]] = FloodPreset(
            key=rec["key"], kind=rec["kind"], event=rec["event"],
            rise_rate=num["rise_height"] / (num["rise_time"] * HOUR),
            fall_rate=num["fall_height"] / (num["fall_time"] * HOUR),
            surge_height=num.get("peak_surge"), location=rec["location"], date=rec["date"],
            source=f"SERRI 70015-001 {table}" + (f"; {rec['note']}" if rec.get("note") else ""),
            extra=num,
        )
    return out


def flood_presets(kind: str | None = None) -> list[FloodPreset]:
    """All presets, optionally only ``"hurricane"``, ``"riverine"`` or ``"generic"`` ones."""
    return [p for p in _load().values() if kind is None or p.kind == kind]


def flood_preset(name: str) -> FloodPreset:
    """A preset by key (``"katrina_2005"``), event name (``"Hurricane Katrina"``) or unique prefix (``"katrina"``)."""
    table = _load()
    key = str(name).strip().lower().replace(" ", "_")
    if key in table:
        return table[key]
    matches = [p for p in table.values()
               if p.event.lower() == str(name).strip().lower() or p.key.startswith(key)
               or p.event.lower().replace(" ", "_").endswith(key)]
    if len(matches) == 1:
        return matches[0]
    hint = f" (ambiguous: {', '.join(p.key for p in matches)})" if matches else ""
    raise InputError(f"unknown flood preset {name!r}{hint}; available: {', '.join(table)}")
