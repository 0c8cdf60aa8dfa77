"""ADH / SMS text files: 2-D meshes (``.3dm``/``.2dm``), ASCII datasets (``.dat``) and the ``.bc`` cards
that tell the length and time units.

Grammar (see ``shared/formats/README.md``; sources: MDAL ``mdal_2dm.cpp``/``mdal_ascii_dat.cpp``,
ADH ``read_geo.c``, the SMS ASCII dataset documentation):

* mesh: ``MESH2D``, ``ND id x y z``, ``E3T|TRI id n1 n2 n3 mat``, ``E4Q id n1..n4 mat``, ``E6T id n1..n6 mat``
  (corner nodes 1, 3, 5 are used), ``E2L``/``E3L`` (1-D, ignored), ``NS n1 n2 ... -nN [id] [name]``
  node strings (kept in :attr:`MeshData.node_strings`; a long string continues on numeric lines or on
  further ``NS`` cards until the negative id), ``MESHNAME``, ``NUM_MATERIALS_PER_ELEM``, SMS
  ``BEGPARAMDEF..ENDPARAMDEF``, ``BEG2DMBC..END2DMBC`` and ``BEGCURVE..ENDCURVE`` blocks (skipped). Free card order, 1-based ids with gaps, ``#``/``!`` comments, CRLF.
* dataset: ``DATASET``/``OBJTYPE``/``BEGSCL|BEGVEC``/``VECTYPE``/``OBJID``/``ND``/``NC``/``NAME``/
  ``RT_JULIAN``/``TIMEUNITS``/``TS istat t`` [+ NC status lines] + values/``ENDDS``; the legacy
  ``SCALAR|VECTOR`` form with ``TS t``. Values are listed per node id (line k is node id k when the
  dataset's ND equals the largest node id; otherwise in ascending id order).
"""
from __future__ import annotations

import re
import struct
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import BreachflowWarning, InputError, ParseError
from ._text import LineReader, as_text, block_values, parse_floats, to_float, to_int

MESH_EXTENSIONS = (".3dm", ".2dm")

#: element card -> (number of node columns, corner node positions used as the face)
ELEMENT_CARDS = {
    "E3T": (3, (0, 1, 2)),
    "TRI": (3, (0, 1, 2)),
    "E4Q": (4, (0, 1, 2, 3)),
    "E6T": (6, (0, 2, 4)),
    "E8Q": (8, (0, 2, 4, 6)),
}
LINE_ELEMENT_CARDS = {"E2L", "E3L"}
#: SMS parameter blocks skipped whole (opening card -> closing card)
SKIP_BLOCKS = {"BEGPARAMDEF": "ENDPARAMDEF", "BEG2DMBC": "END2DMBC", "BEGCURVE": "ENDCURVE"}
KNOWN_MESH_CARDS = {"MESH2D", "MESHNAME", "NUM_MATERIALS_PER_ELEM", "NS", "GP", "GM", "MAT", "ND", *SKIP_BLOCKS,
                    *SKIP_BLOCKS.values(), *ELEMENT_CARDS, *LINE_ELEMENT_CARDS}

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
# mesh
# --------------------------------------------------------------------------------------------------

@dataclass
class NodeString:
    """An ``NS`` node string: node ids in order, the optional string id and name, its first line."""

    node_ids: list
    string_id: int | None
    name: str
    line: int


@dataclass
class MeshData:
    """A parsed 2-D mesh: nodes sorted by id, faces as 0-based node indices (``-1`` padded to 4)."""

    path: Path
    node_ids: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    face_ids: np.ndarray
    faces: np.ndarray
    material: np.ndarray
    name: str = ""
    ignored_cards: dict = field(default_factory=dict)
    node_lines: np.ndarray | None = None  #: line of each node's ND card (sorted like ``node_ids``)
    face_lines: np.ndarray | None = None  #: line of each element card (sorted like ``face_ids``)
    node_strings: list = field(default_factory=list)  #: :class:`NodeString` s (boundary strings)


class _MeshAccumulator:
    def __init__(self, path, strict):
        self.path = path
        self.strict = strict
        self.nodes = []      # arrays (n, 4): id x y z
        self.node_lines = []
        self.elems = []      # (kind, array (n, 1 + k + 1), lines)
        self.name = ""
        self.unknown: dict[str, int] = {}
        self.unknown_line: dict[str, int] = {}
        self.skip_until: str | None = None
        self.skip_from = 0
        self.ns_open = False
        self.ns_ids: list[int] = []
        self.ns_line = 0
        self.node_strings: list[NodeString] = []
        self.seen_header = False
        self.last_line = 1

    # one card line handled in Python (everything except long runs of ND / element cards)
    def line(self, raw: bytes, lineno: int):
        text = as_text(raw, self.path, lineno).strip()
        if not text or text[0] in "#!":
            return
        toks = text.split()
        card = toks[0].upper()
        if self.skip_until:
            if card == self.skip_until:
                self.skip_until = None
            return
        if not self.seen_header:
            if card != "MESH2D":
                raise ParseError(f"not an ADH/SMS 2-D mesh: first card is {toks[0][:30]!r}, expected MESH2D",
                                 path=self.path, line=lineno)
            self.seen_header = True
            return
        if re.fullmatch(r"[-+]?\d+", toks[0]):
            if not self.ns_open:
                raise ParseError(f"unexpected numeric line outside a node string: {text[:60]!r}", path=self.path, line=lineno)
            self._node_string(toks, lineno)
            return
        if self.ns_open and card != "NS":  # a long node string continues on the next NS card
            self._close_ns(lineno)
        if card == "ND":
            vals = _record(toks, 4, 4, self.path, lineno, "ND card (ND id x y z)")
            self.nodes.append(vals[None, :])
            self.node_lines.append(np.array([lineno]))
        elif card in ELEMENT_CARDS:
            k = ELEMENT_CARDS[card][0]
            vals = _record(toks, 1 + k, 2 + k, self.path, lineno, f"{card} card ({card} id n1..n{k} mat)", default_last=1.0)
            self.elems.append((card, vals[None, :], np.array([lineno])))
        elif card in LINE_ELEMENT_CARDS or card in ("GP", "GM", "MAT", "NUM_MATERIALS_PER_ELEM", "MESH2D"):
            return
        elif card == "MESHNAME":
            self.name = text[len(toks[0]):].strip().strip("'\"").strip()
        elif card == "NS":
            self._node_string(toks[1:], lineno)
        elif card in SKIP_BLOCKS:
            self.skip_until = SKIP_BLOCKS[card]
            self.skip_from = lineno
        elif card in SKIP_BLOCKS.values():
            raise ParseError(f"{card} without its opening block", path=self.path, line=lineno)
        else:
            if self.strict:
                raise ParseError(f"unknown card {toks[0][:30]!r} (strict mode)", path=self.path, line=lineno)
            self.unknown[toks[0][:30]] = self.unknown.get(toks[0][:30], 0) + 1
            self.unknown_line.setdefault(toks[0][:30], lineno)

    def _node_string(self, toks, lineno):
        """``NS n1 n2 ... -nN [string id] [name]``; a string may go on over several lines / NS cards."""
        if not self.ns_open:
            self.ns_open = True
            self.ns_ids = []
            self.ns_line = lineno
        for k, t in enumerate(toks):
            if not re.fullmatch(r"[-+]?\d+", t):
                raise ParseError(f"node string: non-integer node id {t[:30]!r}", path=self.path, line=lineno)
            v = int(t)
            self.ns_ids.append(abs(v))
            if v < 0:  # terminator; what follows on the line is the optional string id and name
                self.ns_open = False
                rest = toks[k + 1:]
                sid = None
                if rest and re.fullmatch(r"[-+]?\d+", rest[0]):
                    sid, rest = int(rest[0]), rest[1:]
                self.node_strings.append(NodeString(self.ns_ids, sid, " ".join(rest).strip("'\""), self.ns_line))
                return

    def _close_ns(self, lineno):
        self.ns_open = False
        if self.strict:
            raise ParseError("node string not terminated by a negative node id", path=self.path, line=lineno - 1)
        self.unknown["unterminated NS"] = self.unknown.get("unterminated NS", 0) + 1
        self.unknown_line.setdefault("unterminated NS", self.ns_line)

    def run(self, card: str, block: bytes, n: int, first_line: int):
        """A run of *n* consecutive lines that all start with *card* (fast path)."""
        if self.skip_until:
            return
        if not self.seen_header:
            raise ParseError(f"not an ADH/SMS 2-D mesh: first card is {card!r}, expected MESH2D", path=self.path, line=first_line)
        if self.ns_open:
            self._close_ns(first_line)
        lines = first_line + np.arange(n)
        if card == "ND":
            vals = _run_records(block, b"ND", n, 4, 4, self.path, first_line, "ND card (ND id x y z)")
            self.nodes.append(vals)
            self.node_lines.append(lines)
        else:
            k = ELEMENT_CARDS[card][0]
            vals = _run_records(block, card.encode(), n, 1 + k, 2 + k, self.path, first_line,
                                f"{card} card ({card} id n1..n{k} mat)", default_last=1.0)
            self.elems.append((card, vals, lines))


def _record(toks, min_cols, want_cols, path, lineno, what, default_last=None) -> np.ndarray:
    vals = toks[1:]
    if len(vals) < min_cols:
        raise ParseError(f"{what}: expected {want_cols} values, found {len(vals)}", path=path, line=lineno)
    out = np.empty(want_cols)
    for j in range(want_cols):
        if j >= len(vals):
            out[j] = default_last
            continue
        out[j] = to_float(vals[j], path=path, line=lineno, what=what)
    return out


def _run_records(block, card, n, min_cols, want_cols, path, first_line, what, default_last=None):
    stripped = block.replace(card, b" ", n)
    vals = parse_floats(stripped)
    if vals is not None and np.isfinite(vals).all():
        for c in (want_cols, want_cols + 1, min_cols):
            if vals.size == n * c and c >= min_cols:
                if _columns_consistent(stripped, n, c):
                    arr = vals.reshape(n, c)
                    if c >= want_cols:
                        return np.ascontiguousarray(arr[:, :want_cols])
                    out = np.full((n, want_cols), default_last, dtype=float)
                    out[:, :c] = arr
                    return out
    # slow path: per line, naming the offending line
    out = np.empty((n, want_cols))
    for i, raw in enumerate(block.split(b"\n")[:n]):
        toks = as_text(raw, path, first_line + i).split()
        out[i] = _record(toks, min_cols, want_cols, path, first_line + i, what, default_last)
    return out


def _columns_consistent(block: bytes, n: int, c: int) -> bool:
    """Cheap check that every line holds the same number of tokens (first and last lines checked fully)."""
    lines = block.split(b"\n", 1)
    if len(lines[0].split()) != c:
        return False
    last = block.rstrip(b"\n").rsplit(b"\n", 1)[-1]
    return len(last.split()) == c


_FAST_CARDS = {b"ND": "ND", b"E3T": "E3T", b"TRI": "TRI", b"E4Q": "E4Q", b"E6T": "E6T"}


def read_mesh(path, *, strict: bool = False) -> MeshData:
    """Parse an ADH ``.3dm`` / SMS ``.2dm`` mesh file (see module doc). Raises ParseError on bad input."""
    path = Path(path)
    acc = _MeshAccumulator(path, strict)
    with LineReader(path) as rd:
        while True:
            block, first = rd.read_chunk()
            if not block:
                break
            _scan_chunk(acc, block, first)
        last_line = rd.line_no
    acc.last_line = max(last_line, 1)
    if acc.skip_until:
        raise ParseError(f"block opened at line {acc.skip_from} has no {acc.skip_until}", path=path, line=last_line)
    if not acc.seen_header:
        raise ParseError("empty file: no MESH2D card", path=path, line=max(last_line, 1))
    if acc.ns_open:
        acc._close_ns(last_line + 1)
    if acc.unknown:
        warnings.warn(f"{path}: ignored unsupported card(s) " + ", ".join(
            f"{k!r} (line {acc.unknown_line[k]}" + (f", {n} times)" if n > 1 else ")") for k, n in acc.unknown.items())
            + "; strict=True makes them errors", BreachflowWarning, stacklevel=2)
    return _assemble_mesh(acc)


def _scan_chunk(acc: _MeshAccumulator, block: bytes, first_line: int) -> None:
    arr = np.frombuffer(block, dtype=np.uint8)
    ends = np.flatnonzero(arr == 10)
    if ends.size == 0:
        return
    starts = np.empty_like(ends)
    starts[0] = 0
    starts[1:] = ends[:-1] + 1
    pad = np.concatenate([arr, np.zeros(4, np.uint8)])
    c = [pad[starts + k] for k in range(4)]
    kind = np.zeros(ends.size, dtype=np.int8)
    sep = lambda b: (b == 32) | (b == 9)  # noqa: E731
    codes = {}
    for i, (tok, name) in enumerate(_FAST_CARDS.items(), start=1):
        m = np.ones(ends.size, dtype=bool)
        for j, ch in enumerate(tok):
            m &= c[j] == ch
        m &= sep(c[len(tok)])
        kind[m] = i
        codes[i] = name
    change = np.flatnonzero(np.diff(kind)) + 1
    bounds = np.concatenate([[0], change, [ends.size]])
    for a, b in zip(bounds[:-1], bounds[1:]):
        k = int(kind[a])
        if k == 0 or b - a < 8:  # short runs: the per-line path is simpler and as fast
            for i in range(a, b):
                acc.line(block[starts[i]:ends[i]].rstrip(b"\r"), first_line + i)
        else:
            acc.run(codes[k], block[starts[a]:ends[b - 1] + 1], int(b - a), first_line + int(a))


def _ids(col: np.ndarray, lines: np.ndarray, path, what: str) -> np.ndarray:
    """Integer ids of a 1-D or 2-D float column block; *lines* holds one line number per row."""
    bad = (col != np.floor(col)) | (np.abs(col) > 2**62)
    if bad.any():
        r = np.argwhere(bad)[0]
        raise ParseError(f"{what}: id {col[tuple(r)]:.17g} is not an integer", path=path, line=int(lines[r[0]]))
    return col.astype(np.int64)


def _assemble_mesh(acc: _MeshAccumulator) -> MeshData:
    path = acc.path
    if not acc.nodes:
        if acc.elems:
            card, _, lines = acc.elems[0]
            raise ParseError(f"mesh has no ND (node) cards: the {card} card here references nodes that are never "
                             "defined", path=path, line=int(lines[0]))
        raise ParseError("mesh has no ND (node) cards", path=path, line=acc.last_line)
    nodes = np.concatenate(acc.nodes)
    nlines = np.concatenate(acc.node_lines)
    nid = _ids(nodes[:, 0], nlines, path, "ND card")
    if (nid < 1).any():
        k = int(np.argmax(nid < 1))
        raise ParseError(f"ND card: node id {nid[k]} must be >= 1", path=path, line=int(nlines[k]))
    order = np.argsort(nid, kind="stable")
    sid = nid[order]
    dup = np.flatnonzero(sid[1:] == sid[:-1])
    if dup.size:
        a, b = order[dup[0]], order[dup[0] + 1]
        raise ParseError(f"duplicate node id {sid[dup[0]]} (first defined at line {nlines[a]})", path=path, line=int(nlines[b]))
    x, y, z = (np.ascontiguousarray(nodes[order, k]) for k in (1, 2, 3))
    if not acc.elems:
        raise ParseError("mesh has no 2-D elements (E3T / E4Q / E6T / TRI cards)", path=path)
    del nodes
    itype = np.int32 if sid.size < 2**31 - 1 else np.int64
    width = max(len(ELEMENT_CARDS[card][1]) for card, _, _ in acc.elems)
    id_blocks, mat_blocks, line_blocks, face_blocks = [], [], [], []
    for b in range(len(acc.elems)):
        card, vals, lines = acc.elems[b]
        acc.elems[b] = None  # release the parsed text block as soon as it is converted
        k, corners = ELEMENT_CARDS[card]
        eid = _ids(vals[:, 0], lines, path, f"{card} card")
        conn = _ids(vals[:, 1:1 + k], lines, path, f"{card} card")
        mat_blocks.append(_ids(vals[:, 1 + k], lines, path, f"{card} card material").astype(np.int32))
        del vals
        # every node referenced (corners and mid-side nodes) must exist
        pos = np.searchsorted(sid, conn)
        np.minimum(pos, sid.size - 1, out=pos)
        missing = sid[pos] != conn
        if missing.any():
            r, c = np.argwhere(missing)[0]
            raise ParseError(f"element references node id {conn[r, c]}, which is not defined", path=path, line=int(lines[r]))
        faces = np.full((len(eid), width), -1, dtype=itype)
        faces[:, :len(corners)] = pos[:, list(corners)]
        del pos, conn, missing
        rep = np.zeros(len(eid), dtype=bool)
        for a in range(len(corners)):
            for c in range(a + 1, len(corners)):
                rep |= faces[:, a] == faces[:, c]
        if rep.any():
            r = int(np.argmax(rep))
            raise ParseError(f"element {eid[r]} repeats a node", path=path, line=int(lines[r]))
        id_blocks.append(eid)
        line_blocks.append(lines)
        face_blocks.append(faces)
    eids = np.concatenate(id_blocks)
    del id_blocks
    elines = np.concatenate(line_blocks)
    del line_blocks
    mat = np.concatenate(mat_blocks)
    del mat_blocks
    eorder = np.argsort(eids, kind="stable")
    se = eids[eorder]
    dup = np.flatnonzero(se[1:] == se[:-1])
    if dup.size:
        a, b = eorder[dup[0]], eorder[dup[0] + 1]
        raise ParseError(f"duplicate element id {se[dup[0]]} (first defined at line {elines[a]})", path=path, line=int(elines[b]))
    if acc.strict and (mat < 1).any():
        k = int(np.argmax(mat < 1))
        raise ParseError(f"material id {mat[k]} must be >= 1 (strict mode)", path=path, line=int(elines[k]))
    del eids
    idx = np.concatenate(face_blocks)
    del face_blocks
    if not np.array_equal(eorder, np.arange(eorder.size)):
        idx = idx[eorder]
        mat = mat[eorder]
        elines = elines[eorder]
    return MeshData(path, sid, x, y, z, se, np.ascontiguousarray(idx), mat, acc.name, dict(acc.unknown),
                    node_lines=nlines[order].astype(np.int64), face_lines=elines.astype(np.int64),
                    node_strings=acc.node_strings)


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


# --------------------------------------------------------------------------------------------------
# .bc: units
# --------------------------------------------------------------------------------------------------

@dataclass
class BcInfo:
    path: Path
    gravity: float | None = None
    gravity_line: int | None = None
    length_unit: str | None = None
    output_time_code: int | None = None  # SERIES AWRITE out_units (ADH code) drives the .dat TIMEUNITS


def read_bc(path) -> BcInfo:
    """Read what an ADH ``.bc`` file says about units: ``MP G`` (9.81 → m, 32.2 → ft) and AWRITE units."""
    path = Path(path)
    info = BcInfo(path)
    with LineReader(path) as rd:
        while True:
            raw = rd.readline()
            if raw is None:
                break
            text = as_text(raw, path, rd.line_no).split("!", 1)[0].strip()
            toks = text.split()
            if len(toks) >= 3 and toks[0].upper() == "MP" and toks[1].upper() == "G":
                g = to_float(toks[2], path=path, line=rd.line_no, what="MP G card")
                info.gravity, info.gravity_line = g, rd.line_no
                if abs(g - 9.81) < 0.05:
                    info.length_unit = "m"
                elif abs(g - 32.17) < 0.2:
                    info.length_unit = "ft"
                else:
                    raise ParseError(f"MP G {g:g} is neither ~9.81 (m/s^2) nor ~32.2 (ft/s^2); give units= explicitly",
                                     path=path, line=rd.line_no)
            elif len(toks) >= 5 and toks[0].upper() == "SERIES" and toks[1].upper() == "AWRITE":
                code = to_int(toks[4], path=path, line=rd.line_no, what="SERIES AWRITE output units")
                if code not in ADH_TIME_CODES:
                    raise ParseError(f"SERIES AWRITE output time-unit code {code} not in 0..4", path=path, line=rd.line_no)
                info.output_time_code = code
    return info


# --------------------------------------------------------------------------------------------------
# the reader: mesh + datasets (+ .bc) -> UGRID mesh snapshot
# --------------------------------------------------------------------------------------------------

#: dataset NAME / file-name patterns per role, English and the names national tools write (German
#: Hydro_AS-2D / BASEMENT: Wassertiefe, WSPL; French hauteur, cote; Spanish/Italian calado, tirante...)
_ROLE_PATTERNS = (
    ("water_surface", re.compile(r"water.?surface|\bwse\b|\bwsel?\b|(?<!bed )(?<!bottom )(?<!ground )elevation|stage|"
                                 r"\bhead\b|\beta\b|wasserspiegel|\bwspl?\w*|niveau|\bcote\b|\bnivel\b|waterstand|livello", re.I)),
    ("depth", re.compile(r"depth|\bdep\b|tiefe|hauteur|profondeur|calado|profundidad|tirante|diepte", re.I)),
)
#: names of previous-step / initial-state datasets (ADH "Old Depth", SMS "Initial ...")
_OLD = re.compile(r"\b(old|prev|previous|initial|last|alt|ancien)\b", re.I)
ROLES = ("depth", "water_surface", "velocity", "ignore")


def dataset_role(ds: DatDataset) -> str | None:
    """``velocity`` (any vector), ``depth`` or ``water_surface`` from the NAME (file name as fallback)."""
    if ds.vector:
        return "velocity"
    for text in (ds.name, ds.path.stem):
        for role, pat in _ROLE_PATTERNS:
            if pat.search(text or ""):
                return role
    return None


def assign_roles(datasets: list[DatDataset], roles: dict | None = None) -> tuple[dict, list]:
    """``{role: dataset}`` and the ignored datasets' descriptions.

    *roles* maps a dataset NAME, a file name or a file stem to ``depth``, ``water_surface``,
    ``velocity`` or ``ignore``; other datasets get their role from the name patterns. A dataset whose name
    marks a previous step or initial state ("Old Depth") is used only when nothing else has that role,
    with a warning; when both exist the current one wins and the old one is reported as ignored.
    """
    roles = dict(roles or {})
    for key, role in roles.items():
        if role not in ROLES:
            raise InputError(f"roles[{key!r}] = {role!r}: choose one of {', '.join(ROLES)}")
    given: dict[int, str] = {}
    for key, role in roles.items():
        hits = [i for i, d in enumerate(datasets) if key in (d.name, d.path.name, d.path.stem, str(d.path))]
        if not hits:
            raise InputError(f"roles: no dataset named {key!r}; the datasets are "
                             + ", ".join(f"{d.name!r} ({d.path.name})" for d in datasets))
        for i in hits:
            given[i] = role
    out: dict[str, DatDataset] = {}
    ignored, old = [], []
    for i, d in enumerate(datasets):  # explicit roles first
        role = given.get(i)
        if role in (None, "ignore"):
            continue
        if role in out:
            raise InputError(f"roles: two datasets for {role}: {out[role].name!r} and {d.name!r}")
        if role == "velocity" and not d.vector:
            raise InputError(f"roles: dataset {d.name!r} ({d.path.name}) is scalar; velocity needs a vector dataset")
        if role != "velocity" and d.vector:
            raise InputError(f"roles: dataset {d.name!r} ({d.path.name}) is a vector; {role} needs a scalar dataset")
        out[role] = d
    for i, d in enumerate(datasets):
        if i in given:
            if given[i] == "ignore":
                ignored.append(f"{d.name} ({d.path.name}, roles=ignore)")
            continue
        role = dataset_role(d)
        if role is not None and _OLD.search(d.name or ""):
            old.append((role, d))
            continue
        if role is None or role in out:
            ignored.append(f"{d.name} ({d.path.name})")
            continue
        out[role] = d
    for role, d in old:
        if role in out:
            ignored.append(f"{d.name} ({d.path.name}, a previous-step dataset)")
            warnings.warn(f"{d.path.name}: dataset {d.name!r} looks like a previous step / initial state: ignored, "
                          f"{out[role].name!r} is used as {role}", BreachflowWarning, stacklevel=3)
        else:
            out[role] = d
            warnings.warn(f"{d.path.name}: dataset {d.name!r} looks like a previous step / initial state but is the "
                          f"only {role} dataset: used as {role}; pass roles={{{d.name!r}: '{role}'}} to confirm or "
                          "give the current dataset", BreachflowWarning, stacklevel=3)
    return out, ignored


def _node_values(ds: DatDataset, mesh: MeshData, step: int) -> np.ndarray:
    """Values of one step at the mesh nodes (sorted by id); element values are averaged to nodes."""
    vals = ds.values[step]
    n_node = mesh.node_ids.size
    if ds.on_faces:
        if vals.shape[0] != mesh.faces.shape[0]:
            raise ParseError(f"dataset {ds.name!r} has NC={vals.shape[0]} element values but the mesh has "
                             f"{mesh.faces.shape[0]} elements", path=ds.path, line=ds.ts_lines[step])
        f = mesh.faces
        acc = np.zeros((n_node,) + vals.shape[1:])
        cnt = np.zeros(n_node)
        for k in range(f.shape[1]):
            ok = f[:, k] >= 0
            np.add.at(acc, f[ok, k], vals[ok])
            np.add.at(cnt, f[ok, k], 1.0)
        cnt = np.maximum(cnt, 1.0)
        return acc / (cnt if acc.ndim == 1 else cnt[:, None])
    nd = vals.shape[0]
    max_id = int(mesh.node_ids[-1])
    if nd == max_id == n_node:  # ids 1..n without gaps: line k is node k
        return vals
    if nd == max_id:            # line k is node id k (ADH, MDAL): gaps in ids are skipped lines
        return vals[mesh.node_ids - 1]
    if nd == n_node:            # one line per node in ascending id order
        return vals
    raise ParseError(f"dataset {ds.name!r} has ND={nd} node values but the mesh {mesh.path.name} has {n_node} "
                     f"nodes (largest id {max_id}); adaptive ADH output (*.dat-<n>.<m>) needs its own mesh",
                     path=ds.path, line=ds.ts_lines[step])


def _ccw(mesh: MeshData) -> np.ndarray:
    """Faces reoriented anticlockwise (UGRID), by the signed area of the first three corners."""
    f = mesh.faces.copy()
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    area2 = (mesh.x[b] - mesh.x[a]) * (mesh.y[c] - mesh.y[a]) - (mesh.x[c] - mesh.x[a]) * (mesh.y[b] - mesh.y[a])
    cw = area2 < 0
    if cw.any():
        if f.shape[1] == 3:
            f[cw] = f[cw][:, ::-1]
        else:
            tri = cw & (f[:, 3] < 0)
            quad = cw & (f[:, 3] >= 0)
            f[tri, :3] = f[tri][:, 2::-1]
            f[quad] = f[quad][:, ::-1]
    return f


def open_adh(paths, *, units=None, crs=None, strict=False, time_units=None, plausibility="raise", roles=None,
             **unused):
    """ADH / SMS mesh + datasets → mesh snapshot (SI). See :func:`breachflow.hydro.io.open_snapshot`."""
    from ...units import ureg
    from ..snapshot import check_plausibility, mesh_snapshot
    from . import read_prj, unknown_options

    unknown_options("adh", unused)
    paths = [Path(p) for p in paths]
    meshes = [p for p in paths if p.suffix.lower() in MESH_EXTENSIONS]
    dats = [p for p in paths if p.suffix.lower() not in MESH_EXTENSIONS + (".bc", ".prj")]
    bcs = [p for p in paths if p.suffix.lower() == ".bc"]
    prjs = [p for p in paths if p.suffix.lower() == ".prj"]
    if len(meshes) != 1:
        raise InputError(f"ADH/SMS input needs exactly one mesh file (.3dm/.2dm), got {len(meshes)}: "
                         f"{', '.join(map(str, meshes)) or 'none'}")
    if len(bcs) > 1:
        raise InputError(f"at most one .bc file, got {len(bcs)}")
    bc = read_bc(bcs[0]) if bcs else None
    length_unit = _length_unit(units, bc)
    mesh = read_mesh(meshes[0], strict=strict)
    to_m = float(ureg.Quantity(1.0, length_unit).to("m").magnitude)
    if not dats:
        return _terrain_only(mesh, to_m, length_unit, units, bc, crs or (read_prj(prjs[0]) if prjs else None),
                             [meshes[0], *bcs, *prjs], plausibility)
    datasets = [d for p in dats for d in read_dat(p, strict=strict)]
    roles, ignored = assign_roles(datasets, roles)
    if "depth" not in roles and "water_surface" not in roles:
        raise InputError("no depth or water-surface dataset among " + (", ".join(f"{d.name!r} ({d.path.name})" for d in datasets) or "no .dat files")
                         + "; ADH writes *_dep.dat (NAME \"Depth\"); name the roles with roles={'NAME or file': "
                         "'depth' | 'water_surface' | 'velocity' | 'ignore'}")
    scalar = roles.get("depth") or roles["water_surface"]
    vel = roles.get("velocity")
    t_override = None
    if time_units is not None:
        t_override = time_unit_seconds(time_units)
    elif bc is not None and bc.output_time_code is not None:
        t_override = None  # the .dat's own TIMEUNITS wins; AWRITE only fills a missing one below
    used = [d for d in (scalar, vel) if d is not None]
    times, time_notes = [], []
    for d in used:
        spu = t_override
        if spu is not None:
            note = f"{time_units} (time_units option)"
        elif d.time_units is not None and d.time_units_line == 0:
            note = f"{d.time_units} (binary SMS dataset without TIMEUNITS card: hours, as SMS and MDAL)"
        elif d.time_units is not None:
            where = f"line {d.time_units_line}" if d.time_units_line else "binary card 250"
            note = f"{d.time_units} (TIMEUNITS card, {d.path.name} {where})"
        elif bc is not None and bc.output_time_code is not None:
            spu = ADH_TIME_CODES[bc.output_time_code]
            note = f"{spu:g} s per unit (SERIES AWRITE output code {bc.output_time_code} in {bc.path.name})"
        else:
            note = (f"seconds by default: {d.path.name} has no TIMEUNITS card (ADH's own unit is the second; "
                    "MDAL/QGIS would assume hours for such a file)")
            if len(d.times) > 1:
                warnings.warn(f"{d.path}: no TIMEUNITS card and no .bc SERIES AWRITE: step times taken as seconds "
                              "(ADH's unit; MDAL/QGIS assume hours); pass time_units='hours' (or another unit) if the "
                              "file came from another tool", BreachflowWarning, stacklevel=2)
        time_notes.append(f"{d.path.name}: {note}")
        times.append(np.asarray(d.times, dtype=float) * d.seconds_per_unit(spu))
    nt = len(times[0])
    if vel is not None:
        nt = _align_times(scalar, vel, times[0], times[1])
    if nt == 0:
        raise ParseError(f"dataset {scalar.name!r} has no complete time step", path=scalar.path)
    bed = mesh.z * to_m
    n_node = mesh.node_ids.size
    depth = np.empty((nt, n_node))
    for k in range(nt):  # fill step by step, releasing the parsed step at once (peak memory)
        depth[k] = _node_values(scalar, mesh, k)
        scalar.values[k] = None
    if to_m != 1.0:
        depth *= to_m
    if scalar is not roles.get("depth"):
        depth -= bed[None, :]
    if vel is not None:
        u = np.empty((nt, n_node))
        v = np.empty((nt, n_node))
        for k in range(nt):
            uv = _node_values(vel, mesh, k)
            u[k] = uv[:, 0]
            v[k] = uv[:, 1]
            vel.values[k] = None
        if to_m != 1.0:
            u *= to_m
            v *= to_m
    else:
        warnings.warn("no velocity dataset: velocity set to zero", BreachflowWarning, stacklevel=2)
        u = v = np.zeros_like(depth)
    active = None
    if any(s is not None for s in scalar.status[:nt]):
        if scalar.nc != mesh.faces.shape[0]:
            raise ParseError(f"status flags for NC={scalar.nc} elements but the mesh has {mesh.faces.shape[0]}",
                             path=scalar.path, line=scalar.ts_lines[0])
        active = np.stack([s if s is not None else np.ones(mesh.faces.shape[0], np.int8) for s in scalar.status[:nt]])
    t = times[0][:nt]
    rt = scalar.rt_julian if scalar.rt_julian is not None else (vel.rt_julian if vel is not None else None)
    if rt is not None:
        epoch = (rt - 2440587.5) * 86400.0
        time = (np.round((epoch + t) * 1e3).astype("int64")).astype("datetime64[ms]").astype("datetime64[ns]")
    else:
        time = t
    crs_wkt = crs or (read_prj(prjs[0]) if prjs else None)
    files = [meshes[0], *[d.path for d in used], *bcs, *prjs]
    ds = mesh_snapshot(
        mesh.x * to_m, mesh.y * to_m, _ccw(mesh), bed, depth, u, v, time=time, crs_wkt=crs_wkt,
        source=f"ADH/SMS text export read by breachflow (reader 'adh')", source_files=[str(p) for p in files],
        node_ids=mesh.node_ids, face_ids=mesh.face_ids, face_material=mesh.material, face_active=active,
        copy=False,
    )
    ds.attrs.update(
        breachflow_reader="adh",
        source_length_unit=length_unit,
        source_length_unit_from=("user" if units else f"MP G {bc.gravity:g} in {bc.path.name}"),
        source_datasets="; ".join(f"{role}: {d.name} ({d.path.name}, {len(d.times)} steps)" for role, d in roles.items()),
        source_time_units="; ".join(time_notes),
    )
    faces = [d for d in used if d.on_faces]
    if faces:
        ds.attrs["element_centred_datasets"] = "; ".join(
            f"{d.path.name}: {d.name} ({'NC value lines per step' if d.faces_from_count else '_els file name' if '_els' in d.path.stem.lower() else 'VECTYPE 1'}; "
            "averaged to the nodes)" for d in faces)
    if ignored:
        ds.attrs["ignored_datasets"] = "; ".join(ignored)
    if mesh.name:
        ds["mesh2d"].attrs["long_name"] = f"topology of the 2-D unstructured mesh {mesh.name}"
    partial = [d for d in used if d.partial_step_line is not None]
    if partial:
        ds.attrs["dropped_partial_steps"] = "; ".join(f"{d.path.name}:{d.partial_step_line}" for d in partial)
    locate = _locator(mesh, scalar, vel, scalar is roles.get("depth"))
    return check_plausibility(ds, mode=plausibility, raw_depth=depth, locate=locate)


def _terrain_only(mesh: MeshData, to_m, length_unit, units, bc, crs_wkt, files, plausibility):
    """A mesh without result datasets read as a terrain: bed z at the nodes, depth and velocity 0."""
    from ..snapshot import check_plausibility, mesh_snapshot

    n = mesh.node_ids.size
    zero = np.zeros(n)
    ds = mesh_snapshot(mesh.x * to_m, mesh.y * to_m, _ccw(mesh), mesh.z * to_m, zero, zero, zero.copy(), crs_wkt=crs_wkt,
                       source="ADH/SMS mesh read as a terrain by breachflow (reader 'adh')",
                       source_files=[str(p) for p in files], node_ids=mesh.node_ids, face_ids=mesh.face_ids,
                       face_material=mesh.material)
    ds.attrs.update(breachflow_reader="adh", breachflow_content="terrain: a mesh without result datasets (depth 0, velocity 0)",
                    source_length_unit=length_unit,
                    source_length_unit_from=("user" if units else f"MP G {bc.gravity:g} in {bc.path.name}"))
    if mesh.name:
        ds["mesh2d"].attrs["long_name"] = f"topology of the 2-D unstructured mesh {mesh.name}"
    return check_plausibility(ds, mode=plausibility, locate=_locator(mesh, None, None, True))


def _dataset_row(ds: DatDataset, mesh: MeshData, node: int) -> int:
    """0-based value line within a step of node-centred *ds* holding mesh node index *node*."""
    if ds.nd == int(mesh.node_ids[-1]):  # as in _node_values: line k is node id k
        return int(mesh.node_ids[node]) - 1
    return node


def _locator(mesh: MeshData, scalar: DatDataset, vel: DatDataset | None, scalar_is_depth: bool):
    """``locate(key, index)`` for :func:`check_plausibility`: the file and line of a value at a node."""

    def value_line(ds: DatDataset, step: int, node: int):
        if ds.on_faces:  # element values averaged to the node: name the step and the elements' card lines
            touching = np.flatnonzero((mesh.faces == node).any(axis=1))
            note = ("element-centred values averaged to the node; elements on mesh lines "
                    + ", ".join(str(int(mesh.face_lines[f])) for f in touching[:6]) if mesh.face_lines is not None else "")
            first = ds.value_lines[step]
            return (str(ds.path), int(first + touching[0]) if touching.size else ds.ts_lines[step], note)
        if ds.value_lines[step] is None:  # binary dataset: no lines
            return (str(ds.path), None, f"binary dataset, time step {step}, value {_dataset_row(ds, mesh, node) + 1}")
        return (str(ds.path), int(ds.value_lines[step] + _dataset_row(ds, mesh, node)), "")

    def locate(key, idx):
        node = idx.get("node")
        if node is None:
            return None
        step = idx.get("time", 0)
        if key == "bed_elevation":
            return (str(mesh.path), int(mesh.node_lines[node]), "ND card") if mesh.node_lines is not None else None
        if key == "speed":
            return value_line(vel, step, node) if vel is not None and step < len(vel.value_lines) else None
        if scalar is None or step >= len(scalar.value_lines):
            return None
        path, line, note = value_line(scalar, step, node)
        if not scalar_is_depth and mesh.node_lines is not None:
            note = "; ".join(filter(None, [note, f"depth = water surface - bed of {mesh.path.name} line "
                                                 f"{int(mesh.node_lines[node])}"]))
        return path, line, note

    return locate


def _length_unit(units, bc: BcInfo | None) -> str:
    from ...units import ureg

    if units is not None:
        try:
            q = ureg.Quantity(1.0, str(units))
        except Exception:
            raise InputError(f"units={units!r}: not a length unit (use 'm' or 'ft')") from None
        if q.dimensionality != ureg.Quantity(1.0, "m").dimensionality:
            raise InputError(f"units={units!r}: not a length unit (use 'm' or 'ft')")
        if bc is not None and bc.length_unit and ureg.Quantity(1.0, str(units)).to("m").magnitude != ureg.Quantity(1.0, bc.length_unit).to("m").magnitude:
            warnings.warn(f"units={units!r} given but {bc.path.name}:{bc.gravity_line} has MP G {bc.gravity:g} "
                          f"(suggesting {bc.length_unit}); using {units!r}", BreachflowWarning, stacklevel=3)
        return str(units)
    if bc is not None and bc.length_unit:
        return bc.length_unit
    if bc is not None:
        raise InputError(f"{bc.path}: no MP G card (gravity), so metres cannot be told from feet; pass "
                         "units='m' or units='ft'")
    raise InputError("ADH/SMS files carry no units: pass units='m' or units='ft' (or include the model's .bc "
                     "file, whose MP G card tells metres from feet)")


def _align_times(a: DatDataset, b: DatDataset, ta: np.ndarray, tb: np.ndarray) -> int:
    n = min(ta.size, tb.size)
    if not np.allclose(ta[:n], tb[:n], rtol=1e-9, atol=1e-6):
        k = int(np.argmax(~np.isclose(ta[:n], tb[:n], rtol=1e-9, atol=1e-6)))
        raise ParseError(f"time step {k} of {a.name!r} is at t={ta[k]:g} s but {b.name!r} ({b.path.name}) "
                         f"has t={tb[k]:g} s: depth and velocity steps are inconsistent", path=a.path, line=a.ts_lines[k])
    if ta.size != tb.size:
        longer, shorter = (a, b) if ta.size > tb.size else (b, a)
        if shorter.partial_step_line is None and shorter.complete and longer.complete:
            raise ParseError(f"{a.name!r} has {ta.size} time steps but {b.name!r} ({b.path.name}) has {tb.size}",
                             path=a.path, line=a.ts_lines[-1] if a.ts_lines else None)
        warnings.warn(f"{longer.path.name} has {max(ta.size, tb.size)} steps, {shorter.path.name} {n}: "
                      f"using the {n} common step(s)", BreachflowWarning, stacklevel=3)
    return n
