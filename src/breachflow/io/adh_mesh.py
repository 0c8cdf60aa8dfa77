"""ADH / SMS 2-D meshes (``.3dm`` / ``.2dm``).

Grammar (MDAL ``mdal_2dm.cpp``, ADH ``read_geo.c``): ``MESH2D`` (older
files append numbers), ``ND id x y z``, ``E3T|TRI id n1 n2 n3 mat``, ``E4Q id n1..n4 mat``, ``E6T id n1..n6
mat`` (corner nodes 1, 3, 5 are used), ``E2L``/``E3L`` (1-D, ignored), ``NS n1 n2 ... -nN [id] [name]`` node
strings (kept in :attr:`MeshData.node_strings`; a long string continues on numeric lines or on further
``NS`` cards until the negative id), ``MESHNAME``, ``NUM_MATERIALS_PER_ELEM``, SMS ``BEGPARAMDEF..ENDPARAMDEF``,
``BEG2DMBC..END2DMBC`` and ``BEGCURVE..ENDCURVE`` blocks (skipped). Free card order, 1-based ids with gaps,
``#``/``!`` comments, CRLF. Unsupported cards are warned about with their first line (errors with
``strict=True``). Long runs of ``ND`` / element cards are parsed with one C call per run.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, ParseError
from ._text import LineReader, as_text, parse_floats, to_float

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
#: cards without bearing on the geometry, skipped silently (SMS / TUFLOW write NO_MOVE_EQ9_CENTER_NODE)
IGNORED_CARDS = {"GP", "GM", "MAT", "NUM_MATERIALS_PER_ELEM", "MESH2D", "NO_MOVE_EQ9_CENTER_NODE"}
KNOWN_MESH_CARDS = {"MESH2D", "MESHNAME", "NS", "ND", *IGNORED_CARDS, *SKIP_BLOCKS,
                    *SKIP_BLOCKS.values(), *ELEMENT_CARDS, *LINE_ELEMENT_CARDS}


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
        elif card in LINE_ELEMENT_CARDS or card in IGNORED_CARDS:
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
        first_cols = len(stripped.split(b"\n", 1)[0].split())  # extra trailing columns (TUFLOW: ND id x y z 2 0. 0. 0.)
        for c in dict.fromkeys((want_cols, want_cols + 1, min_cols, first_cols)):
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


def _small_int(a: np.ndarray) -> np.ndarray:
    """Line numbers in the narrowest integer type that holds them (memory of million-node meshes)."""
    return a.astype(np.int32 if a.size == 0 or a.max() < 2**31 - 1 else np.int64)


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
                    node_lines=_small_int(nlines[order]), face_lines=_small_int(elines),
                    node_strings=acc.node_strings)
