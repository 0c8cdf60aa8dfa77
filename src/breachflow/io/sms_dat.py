"""SMS ASCII datasets (``.dat``: ADH ``*_dep.dat`` / ``*_vel.dat``, SMS, TUFLOW, BASEMENT, Hydro_AS-2D).

Grammar (MDAL ``mdal_ascii_dat.cpp``, the SMS ASCII dataset documentation):
``DATASET``/``OBJTYPE``/``BEGSCL|BEGVEC``/``VECTYPE``/``OBJID``/``ND``/``NC``/``NAME``/``RT_JULIAN``/
``TIMEUNITS``/``TS istat t`` [+ NC status lines] + values/``ENDDS``. Values are listed per node id (line k
is node id k when the dataset's ND equals the largest node id; otherwise in ascending id order).
Real-world variants: the legacy ``SCALAR|VECTOR`` form with ``TS t`` (which may repeat ``SCALAR``, ``ND``,
``ST``, ``TIMEUNITS`` before every step, or start at ``TS`` without ``ND``); element-centred datasets
(``_els`` in the file name as BASEMENT / MDAL, ``VECTYPE 1``, or steps of NC value lines); tabs; a value
line where a card is expected (one value too many) is an error naming the line; binary SMS datasets are
handed to :mod:`.sms_binary`.
"""
from __future__ import annotations

import re
import struct
import warnings
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, ParseError
from ._text import LineReader, as_text, block_values, to_float, to_int
from .sms_dataset import ADH_TIME_CODES, SMS_TIME_CODES, TIME_WORDS, DatDataset, time_unit_seconds  # noqa: F401


def read_dat(path, *, strict: bool = False) -> list[DatDataset]:
    """Parse an SMS ASCII dataset file into its datasets (see module doc).

    A dataset without ``ENDDS`` (crashed run) keeps its complete steps; a partial last step is dropped
    and reported with a :class:`BreachflowWarning` naming the line.
    """
    path = Path(path)
    if _refuse_binary(path):
        from .sms_binary import read_binary_dat

        return read_binary_dat(path)
    out: list[DatDataset] = []
    unknown: dict[str, int] = {}
    els = "_els" in path.stem.lower()  # BASEMENT / MDAL convention: values per element (NC), not per node
    with LineReader(path) as rd:
        first = None
        while first is None:
            raw = rd.readline()
            if raw is None:
                raise ParseError("empty file: no DATASET / SCALAR / VECTOR card", path=path, line=max(rd.line_no, 1))
            t = as_text(raw, path, rd.line_no).strip()
            if t and not t.startswith("#"):
                first = t
        head = first.split()[0].upper()
        legacy = head in ("SCALAR", "VECTOR", "TS", "ND", "TIMEUNITS")  # old format; may start at TS (MDAL)
        if head != "DATASET" and not legacy:
            raise ParseError(f"not an SMS ASCII dataset: first card {first[:30]!r} (expected DATASET, SCALAR or VECTOR)",
                             path=path, line=rd.line_no)
        cur: DatDataset | None = None
        top: dict = {}
        pending = None
        if legacy:
            cur = DatDataset(path, name=path.stem, vector=head == "VECTOR", line=rd.line_no, on_faces=els)
            if head not in ("SCALAR", "VECTOR"):
                pending = (first, rd.line_no)
        while True:
            if pending is not None:
                (text, lineno), pending = pending, None
            else:
                raw = rd.readline()
                if raw is None:
                    break
                lineno = rd.line_no
                text = as_text(raw, path, lineno)
            text = text.replace("\t", " ").strip()
            if not text or text[0] in "#!":
                continue
            toks = text.split()
            card = toks[0].upper()
            if _is_number(toks[0]):
                raise ParseError(_stray_value_message(cur, lineno), path=path, line=lineno)
            if card in ("BEGSCL", "BEGVEC"):
                if cur is not None and not legacy:
                    raise ParseError(f"{card}: new dataset before ENDDS of the dataset begun at line {cur.line}", path=path, line=lineno)
                cur = DatDataset(path, name=path.stem, vector=card == "BEGVEC", line=lineno, on_faces=els,
                                 nd=top.get("nd"), nc=top.get("nc"), time_units=top.get("tu"), rt_julian=top.get("rt"),
                                 time_units_line=top.get("tu_line"))
                continue
            if card == "ENDDS":
                if cur is None:
                    raise ParseError("ENDDS without an open dataset", path=path, line=lineno)
                cur.complete = True
                out.append(cur)
                cur = None
                continue
            target = cur
            if card in ("ND", "NC"):
                n = to_int(toks[1] if len(toks) > 1 else None, path=path, line=lineno, what=f"{card} card")
                if n < 0:
                    raise ParseError(f"{card} card: count {n} is negative", path=path, line=lineno)
                key = card.lower()
                if target is None:
                    top[key] = n
                else:
                    if target.times and not (legacy and getattr(target, key) == n):  # legacy files repeat the header
                        raise ParseError(f"{card} {n} after the first time step (the dataset has {card} "
                                         f"{getattr(target, key)})", path=path, line=lineno)
                    setattr(target, key, n)
            elif card == "NAME":
                name = text[len(toks[0]):].strip()
                name = name.strip().strip("'\"").strip() if name else ""
                if target is None:
                    top["name"] = name
                else:
                    target.name = name or target.name
            elif card == "TIMEUNITS":
                if len(toks) < 2:
                    raise ParseError("TIMEUNITS card without a value", path=path, line=lineno)
                time_unit_seconds(toks[1], path=path, line=lineno)  # validate now
                if target is None:
                    top["tu"], top["tu_line"] = toks[1], lineno
                else:
                    if target.times and target.time_units is not None and \
                            time_unit_seconds(target.time_units) != time_unit_seconds(toks[1]):
                        raise ParseError(f"TIMEUNITS {toks[1]} after steps in {target.time_units}", path=path, line=lineno)
                    target.time_units, target.time_units_line = toks[1], lineno
            elif card == "RT_JULIAN":
                rt = to_float(toks[1] if len(toks) > 1 else None, path=path, line=lineno, what="RT_JULIAN card")
                if target is None:
                    top["rt"] = rt
                else:
                    target.rt_julian = rt
            elif card == "OBJTYPE":
                obj = toks[1].strip("'\"").lower() if len(toks) > 1 else ""
                if obj not in ("mesh2d", "mesh"):
                    raise ParseError(f"OBJTYPE {obj!r} not supported (only mesh2d)", path=path, line=lineno)
            elif card == "VECTYPE":
                vt = to_int(toks[1] if len(toks) > 1 else None, path=path, line=lineno, what="VECTYPE card")
                if vt not in (0, 1):
                    raise ParseError(f"VECTYPE {vt} must be 0 (nodes) or 1 (elements)", path=path, line=lineno)
                if target is not None:
                    target.on_faces = vt == 1
                else:
                    top["vectype"] = vt
            elif card in ("SCALAR", "VECTOR") and legacy and cur is not None:
                if (card == "VECTOR") != cur.vector:  # a repeated legacy header must not change the kind
                    raise ParseError(f"{card} card in a {'VECTOR' if cur.vector else 'SCALAR'} dataset", path=path, line=lineno)
            elif card in ("OBJID", "DATASET", "SCALAR", "VECTOR", "BEGDSET", "TIMEZONE", "DATAREF", "RT_HOURS", "ST"):
                pass
            elif card == "TS":
                if cur is None:
                    raise ParseError("TS card outside a dataset (missing BEGSCL/BEGVEC)", path=path, line=lineno)
                if not _read_step(rd, cur, toks, lineno, legacy):
                    out.append(cur)
                    cur = None
                    break
            else:
                if strict:
                    raise ParseError(f"unknown card {toks[0][:30]!r} (strict mode)", path=path, line=lineno)
                unknown.setdefault(toks[0][:30], lineno)
        if cur is not None:
            if not legacy:
                warnings.warn(f"{path}: dataset {cur.name!r} has no ENDDS (crashed or running model?); "
                              f"kept {len(cur.times)} complete time step(s)", BreachflowWarning, stacklevel=2)
            out.append(cur)
    if unknown:
        warnings.warn(f"{path}: ignored unsupported card(s) " + ", ".join(f"{k!r} (line {n})" for k, n in unknown.items())
                      + "; strict=True makes them errors", BreachflowWarning, stacklevel=2)
    if not out:
        raise ParseError("no dataset (BEGSCL/BEGVEC block) in the file", path=path)
    return out


def _read_step(rd: LineReader, ds: DatDataset, toks, lineno: int, legacy: bool) -> bool:
    """Read one TS block into *ds*; False when the file ended inside it (partial step, dropped)."""
    path = ds.path
    if len(toks) >= 3 and not legacy:
        istat = to_int(toks[1], path=path, line=lineno, what="TS card status flag")
        t = to_float(toks[2], path=path, line=lineno, what="TS card time")
    elif len(toks) == 2 or (legacy and len(toks) >= 2):
        istat, t = 0, to_float(toks[-1], path=path, line=lineno, what="TS card time")
    else:
        raise ParseError("TS card needs a time (TS istat time)", path=path, line=lineno)
    if istat not in (0, 1):
        raise ParseError(f"TS status flag {istat} must be 0 or 1", path=path, line=lineno)
    if ds.times and t <= ds.times[-1]:
        raise ParseError(f"time {t:g} does not increase (previous step {ds.times[-1]:g})", path=path, line=lineno)
    n = ds.nc if ds.on_faces else ds.nd
    if n is None and legacy and not ds.times:  # old files may have no ND card: the first step's lines tell
        n = _count_value_lines(rd)
        setattr(ds, "nc" if ds.on_faces else "nd", n)
    if n is None:
        raise ParseError(f"TS card before the {'NC' if ds.on_faces else 'ND'} count card", path=path, line=lineno)
    status = None
    if istat == 1:
        if ds.nc is None:
            raise ParseError("TS with status flags needs the NC card first", path=path, line=lineno)
        block, got = rd.read_lines(ds.nc)
        if got < ds.nc or _has_card(block):
            return _partial_or_error(ds, block, got, ds.nc, lineno, lineno + 1)
        st = block_values(block, ds.nc, 1, path=path, first_line=lineno + 1, what="element status flag")[:, 0]
        bad = np.flatnonzero((st != 0) & (st != 1))
        if bad.size:
            raise ParseError(f"element status flag {st[bad[0]]:g} must be 0 or 1", path=path, line=lineno + 1 + int(bad[0]))
        status = st.astype(np.int8)
    first = rd.line_no + 1
    block, got = rd.read_lines(n)
    if got < n or _has_card(block):
        m = _CARD_LINE.search(block)
        i = block.count(b"\n", 0, m.start()) if m else got
        if not ds.times and not ds.on_faces and ds.nc and ds.nc != n and i == ds.nc and status is None:
            # values per element (NC lines) rather than per node: element-centred dataset (TUFLOW, BASEMENT)
            rd.push_back(block[_line_offset(block, i):], got - i)
            block, ds.on_faces, ds.faces_from_count, n = block[:_line_offset(block, i)], True, True, ds.nc
        else:
            return _partial_or_error(ds, block, got, n, lineno, first)
    if ds.vector:
        ncols = len(block.split(b"\n", 1)[0].split())
        if ncols not in (2, 3):
            raise ParseError(f"vector dataset: expected 2 or 3 columns, found {ncols}", path=path, line=first)
        vals = block_values(block, n, ncols, path=path, first_line=first, what="vector value")
        if ncols == 3:
            vals = np.ascontiguousarray(vals[:, :2])  # release the third (zero) column
    else:
        vals = block_values(block, n, 1, path=path, first_line=first, what="scalar value")[:, 0]
    ds.times.append(t)
    ds.values.append(vals)
    ds.status.append(status)
    ds.ts_lines.append(lineno)
    ds.value_lines.append(first)
    return True


def _line_offset(block: bytes, i: int) -> int:
    """Byte offset of line *i* (0-based) in *block*."""
    pos = 0
    for _ in range(i):
        pos = block.index(b"\n", pos) + 1
    return pos


def _count_value_lines(rd: LineReader) -> int:
    """How many value lines follow (up to the next card or the end), without consuming them."""
    lines = []
    n = 0
    while True:
        raw = rd.readline()
        if raw is None:
            break
        lines.append(raw)
        t = raw.split()
        if t and not _is_number(t[0].decode("latin-1")):
            break
        n += 1 if t else 0
    rd.push_back(b"".join(ln + b"\n" for ln in lines), len(lines))
    return n


#: first 4 bytes of a binary SMS dataset file: the version card 3000 as a 32-bit integer (MDAL mdal_binary_dat.cpp)
BINARY_DAT_MAGIC = (struct.pack("<i", 3000), struct.pack(">i", 3000))


def _refuse_binary(path: Path) -> bool:
    """True for a binary SMS dataset (read by :mod:`.sms_binary`); other binary files are refused."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(512)
    except OSError as exc:
        raise ParseError(f"cannot open file ({exc.strerror})", path=path) from None
    if head[:4] == BINARY_DAT_MAGIC[0]:
        return True
    if head[:4] == BINARY_DAT_MAGIC[1]:
        raise ParseError("big-endian binary SMS dataset (version card 3000): not supported; export it from SMS as "
                         "an ASCII dataset (.dat with DATASET / BEGSCL cards)", path=path, line=1)
    if b"\0" in head:
        raise ParseError("binary file (NUL bytes): not a text (ASCII) file of this format", path=path, line=1)


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _stray_value_message(ds: DatDataset | None, lineno: int) -> str:
    """Why a value line where a card (TS, ENDDS, ...) is expected is an error: usually one value too many."""
    msg = "value line where a card (TS, ENDDS, ...) is expected"
    if ds is not None and ds.times:
        n = ds.nc if ds.on_faces else ds.nd
        key = "NC" if ds.on_faces else "ND"
        if ds.value_lines[-1] + n == lineno:
            return (f"{msg}: the time step at line {ds.ts_lines[-1]} already has its {key}={n} values; the step has "
                    f"more values than {key} (a value too many would shift every later value)")
        return f"{msg} after the time step at line {ds.ts_lines[-1]} ({key}={n})"
    return msg


_CARD_LINE = re.compile(rb"(?m)^[ \t]*(?![nN][aA][nN]|[iI][nN][fF])([A-Za-z_]+)")


def _has_card(block: bytes) -> bool:
    """True when a line of a numeric block starts with a word (a card such as TS or ENDDS)."""
    if not block.translate(None, b"0123456789.+-eE \t\r\n"):  # only number characters: fast exit
        return False
    return _CARD_LINE.search(block) is not None


def _partial_or_error(ds: DatDataset, block: bytes, got: int, n: int, ts_line: int, first: int) -> bool:
    m = _CARD_LINE.search(block)
    if m:
        i = block.count(b"\n", 0, m.start())
        raise ParseError(f"time step at line {ts_line} has {i} value line(s), expected {n} "
                         f"(found card {as_text(m.group(1), ds.path, 0)[:30]!r})", path=ds.path, line=first + i)
    # end of file inside the step: a crashed run's partial last step
    ds.partial_step_line = ts_line
    warnings.warn(f"{ds.path}:{ts_line}: partial last time step ({got} of {n} lines) dropped; "
                  f"kept {len(ds.times)} complete step(s)", BreachflowWarning, stacklevel=3)
    return False
