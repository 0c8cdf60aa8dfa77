"""One SMS dataset (a ``BEGSCL``/``BEGVEC`` ... ``ENDDS`` block, or a binary dataset) as the ``.dat`` readers
return it (:mod:`.sms_dat` for ASCII files, :mod:`.sms_binary` for binary ones), and the TIMEUNITS words and
codes of SMS and ADH files."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ParseError

#: seconds per unit for TIMEUNITS words / abbreviations
TIME_WORDS = {
    "SECONDS": 1.0, "SECOND": 1.0, "SEC": 1.0, "S": 1.0, "SE": 1.0,
    "MINUTES": 60.0, "MINUTE": 60.0, "MIN": 60.0, "MI": 60.0, "M": 60.0,
    "HOURS": 3600.0, "HOUR": 3600.0, "HR": 3600.0, "HRS": 3600.0, "H": 3600.0, "HO": 3600.0,
    "DAYS": 86400.0, "DAY": 86400.0, "D": 86400.0, "DA": 86400.0,
    "WEEKS": 604800.0, "WEEK": 604800.0, "WK": 604800.0, "W": 604800.0, "WE": 604800.0,
}
#: SMS / MDAL numeric TIMEUNITS codes in ``.dat`` files (MDAL convertTimeDataToHours: 0 h, 1 min, 2 s)
SMS_TIME_CODES = {0: 3600.0, 1: 60.0, 2: 1.0}
#: ADH ``.bc`` time-unit codes (SERIES / TC cards): 0 s, 1 min, 2 h, 3 d, 4 wk
ADH_TIME_CODES = {0: 1.0, 1: 60.0, 2: 3600.0, 3: 86400.0, 4: 604800.0}


# --------------------------------------------------------------------------------------------------
# datasets
# --------------------------------------------------------------------------------------------------

@dataclass
class DatDataset:
    """One dataset (BEGSCL/BEGVEC ... ENDDS block) of an SMS ASCII ``.dat`` file."""

    path: Path
    name: str
    vector: bool
    on_faces: bool = False
    nd: int | None = None
    nc: int | None = None
    time_units: str | None = None
    rt_julian: float | None = None
    times: list = field(default_factory=list)
    values: list = field(default_factory=list)  # per step: (n,) or (n, 2)
    status: list = field(default_factory=list)  # per step: (nc,) int8 or None
    time_units_line: int | None = None
    faces_from_count: bool = False  # element values detected by the step's line count (NC, not ND)
    ts_lines: list = field(default_factory=list)
    value_lines: list = field(default_factory=list)  # per step: line of the first value
    complete: bool = False          # ENDDS seen
    partial_step_line: int | None = None
    line: int = 0

    def seconds_per_unit(self, override: float | None = None) -> float:
        if override is not None:
            return override
        return time_unit_seconds(self.time_units, path=self.path, line=self.line)

    @property
    def kind(self) -> str:
        return "vector" if self.vector else "scalar"


def time_unit_seconds(text, *, path=None, line=None, numeric_codes=SMS_TIME_CODES) -> float:
    """Seconds per unit of a TIMEUNITS value (word, abbreviation or numeric code); None means seconds."""
    if text is None:
        return 1.0
    t = str(text).strip().strip("'\"").upper()
    if t in TIME_WORDS:
        return TIME_WORDS[t]
    try:
        code = int(t)
    except ValueError:
        raise ParseError(f"unknown TIMEUNITS {text!r}", path=path, line=line) from None
    if code not in numeric_codes:
        raise ParseError(f"unknown numeric TIMEUNITS code {code}", path=path, line=line)
    return numeric_codes[code]
