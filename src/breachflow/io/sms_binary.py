"""Binary SMS datasets (``.dat`` written by SMS and TUFLOW), read into the same :class:`DatDataset` as the
ASCII form.

Layout (little-endian; MDAL ``mdal_binary_dat.cpp``, the SMS binary dataset format): the version card
3000 (int32), then int32 cards, some followed by data: ``100 OBJTYPE`` (int32, 3 = 2-D mesh),
``110 SFLT`` (float size, 4), ``120 SFLG`` (flag size, 1 or 4), ``130 BEGSCL`` / ``140 BEGVEC``,
``150 VECTYPE`` (int32, 0 = at nodes), ``160 OBJID`` (int32), ``170 NUMDATA`` (int32, values per step),
``180 NUMCELLS`` (int32, elements), ``190 NAME`` (40 bytes), ``240 RT_JULIAN`` (flag + float64),
``250 TIMEUNITS`` (int32: 0 h, 1 min, 2 s, 4 d), ``200 TS`` (flag ``istat``, float32 time, NUMCELLS
status flags when istat, then NUMDATA float32 values, two per node for vectors), ``210 ENDDS``.
Without a TIMEUNITS card times are hours (MDAL, SMS). A step at 99999 h is TUFLOW's maximum over the
run, not a time: it is left out (and named in a warning).
"""
from __future__ import annotations

import os
import struct
import warnings
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, ParseError
from .sms_dataset import DatDataset

VERSION = 3000
CARDS = {100: "OBJTYPE", 110: "SFLT", 120: "SFLG", 130: "BEGSCL", 140: "BEGVEC", 150: "VECTYPE", 160: "OBJID",
         170: "NUMDATA", 180: "NUMCELLS", 190: "NAME", 200: "TS", 210: "ENDDS", 240: "RT_JULIAN", 250: "TIMEUNITS"}
TIME_CODES = {0: "HOURS", 1: "MINUTES", 2: "SECONDS", 4: "DAYS"}


class _Bytes:
    def __init__(self, path: Path):
        self.path = path
        self.fh = open(path, "rb")

    def take(self, n: int, what: str) -> bytes:
        pos = self.fh.tell()
        if n < 0:
            raise ParseError(f"binary SMS dataset: negative size of {what} (byte {pos}; NUMDATA / NUMCELLS < 0?)", path=self.path)
        left = os.fstat(self.fh.fileno()).st_size - pos
        if n > left:  # checked before reading: a corrupt NUMDATA would otherwise allocate gigabytes
            raise ParseError(f"binary SMS dataset ends inside {what} (byte {pos}: {n:,} bytes announced by the "
                             f"header counts, {left:,} left in the file)", path=self.path)
        b = self.fh.read(n)
        if len(b) != n:
            raise ParseError(f"binary SMS dataset ends inside {what} (byte {pos})", path=self.path)
        return b

    def i32(self, what: str) -> int:
        return struct.unpack("<i", self.take(4, what))[0]

    def flag(self, size: int, what: str) -> int:
        b = self.take(size, what)
        return b[0] if size == 1 else struct.unpack("<i", b)[0]


def read_binary_dat(path) -> list:
    """Parse a binary SMS dataset file (see the module doc) into :class:`~.sms_dataset.DatDataset` objects."""
    path = Path(path)
    rd = _Bytes(path)
    try:
        if rd.i32("the version card") != VERSION:
            raise ParseError("not a binary SMS dataset (version card is not 3000)", path=path)
        ds = DatDataset(path, name=path.stem, vector=False, time_units="HOURS", time_units_line=0)
        sflg, maxima = 1, 0
        while True:
            pos = rd.fh.tell()
            head = rd.fh.read(4)
            if len(head) < 4:
                warnings.warn(f"{path}: binary dataset without ENDDS card; kept {len(ds.times)} step(s)",
                              BreachflowWarning, stacklevel=3)
                break
            card = struct.unpack("<i", head)[0]
            name = CARDS.get(card)
            if name is None:
                raise ParseError(f"binary SMS dataset: unknown card {card} at byte {pos}: not supported", path=path)
            if name == "ENDDS":
                ds.complete = True
                break
            if name == "OBJTYPE":
                if (obj := rd.i32("OBJTYPE")) != 3:
                    raise ParseError(f"binary SMS dataset: object type {obj} not supported (only 3 = 2-D mesh)", path=path)
            elif name == "SFLT":
                if (size := rd.i32("SFLT")) != 4:
                    raise ParseError(f"binary SMS dataset: float size {size} not supported (only 4)", path=path)
            elif name == "SFLG":
                sflg = rd.i32("SFLG")
                if sflg not in (1, 4):
                    raise ParseError(f"binary SMS dataset: flag size {sflg} not supported (1 or 4)", path=path)
            elif name in ("BEGSCL", "BEGVEC"):
                ds.vector = name == "BEGVEC"
            elif name == "VECTYPE":
                if (vt := rd.i32("VECTYPE")) != 0:
                    raise ParseError(f"binary SMS dataset: VECTYPE {vt} (values at elements) not supported", path=path)
            elif name == "OBJID":
                rd.i32("OBJID")
            elif name == "NUMDATA":
                ds.nd = rd.i32("NUMDATA")
            elif name == "NUMCELLS":
                ds.nc = rd.i32("NUMCELLS")
            elif name == "NAME":
                ds.name = rd.take(40, "NAME").split(b"\0", 1)[0].decode("latin-1").strip() or path.stem
            elif name == "RT_JULIAN":
                rd.flag(sflg, "RT_JULIAN")
                ds.rt_julian = struct.unpack("<d", rd.take(8, "RT_JULIAN"))[0]
            elif name == "TIMEUNITS":
                code = rd.i32("TIMEUNITS")
                if code not in TIME_CODES:
                    raise ParseError(f"binary SMS dataset: TIMEUNITS code {code} not supported", path=path)
                ds.time_units, ds.time_units_line = TIME_CODES[code], None
            elif name == "TS":
                if ds.nd is None:
                    raise ParseError(f"binary SMS dataset: TS card (byte {pos}) before NUMDATA", path=path)
                istat = rd.flag(sflg, "TS status flag")
                t = float(struct.unpack("<f", rd.take(4, "TS time"))[0])
                status = None
                if istat:
                    st = np.frombuffer(rd.take(sflg * (ds.nc or 0), "element status flags"), dtype="u1" if sflg == 1 else "<i4")
                    status = (st != 0).astype(np.int8)
                k = 2 if ds.vector else 1
                vals = np.frombuffer(rd.take(4 * k * ds.nd, f"the values of the step at byte {pos}"), dtype="<f4").astype(float)
                if t == 99999.0:  # TUFLOW maxima
                    maxima += 1
                    continue
                ds.times.append(t)
                ds.values.append(vals.reshape(ds.nd, 2) if ds.vector else vals)
                ds.status.append(status)
                ds.ts_lines.append(None)
                ds.value_lines.append(None)
        if maxima:
            warnings.warn(f"{path}: {maxima} step(s) at t = 99999 (TUFLOW maxima, not times) left out",
                          BreachflowWarning, stacklevel=3)
    finally:
        rd.fh.close()
    if not ds.times:
        raise ParseError("binary SMS dataset has no time step", path=path)
    return [ds]
