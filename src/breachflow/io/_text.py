"""Fast, line-number-aware reading of large whitespace-separated text files.

Numeric blocks are parsed with one C call per block (``np.fromstring`` over the block's bytes); only
when the count or a token is wrong do we fall back to a line-by-line scan that names the offending
line. Files are read in chunks, never whole, so memory stays near the size of the parsed arrays.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import ParseError

CHUNK = 1 << 24  # 16 MiB


def parse_floats(block: bytes) -> np.ndarray | None:
    """All numbers in *block* (whitespace separated) or None if a token is not a number."""
    if not block.strip():
        return np.empty(0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        try:
            return np.fromstring(block, sep=" ")
        except (ValueError, DeprecationWarning):
            return None


def as_text(raw: bytes, path, line: int) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        try:
            return raw.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes every byte
            raise ParseError("undecodable bytes", path=path, line=line) from None


class LineReader:
    """Sequential reader of lines and blocks of lines from a binary file, tracking 1-based line numbers.

    ``line_no`` is the number of the last line returned (0 before the first).
    """

    def __init__(self, path):
        self.path = Path(path)
        try:
            self._f = open(self.path, "rb")
        except OSError as exc:
            raise ParseError(f"cannot open file ({exc.strerror})", path=self.path) from None
        self._buf = b""
        self._pos = 0
        self._eof = False
        self.line_no = 0

    def close(self):
        self._f.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _fill(self) -> bool:
        if self._eof:
            return False
        data = self._f.read(CHUNK)
        if not data:
            self._eof = True
            return False
        self._buf = self._buf[self._pos:] + data
        self._pos = 0
        return True

    def readline(self) -> bytes | None:
        """Next line without its end-of-line bytes, or None at end of file."""
        while True:
            k = self._buf.find(b"\n", self._pos)
            if k >= 0:
                line = self._buf[self._pos:k]
                self._pos = k + 1
                self.line_no += 1
                return line.rstrip(b"\r")
            if not self._fill():
                if self._pos < len(self._buf):
                    line = self._buf[self._pos:]
                    self._pos = len(self._buf)
                    self.line_no += 1
                    return line.rstrip(b"\r")
                return None

    def peek_line(self) -> bytes | None:
        """The next line without consuming it."""
        while True:
            k = self._buf.find(b"\n", self._pos)
            if k >= 0:
                return self._buf[self._pos:k].rstrip(b"\r")
            if not self._fill():
                return self._buf[self._pos:].rstrip(b"\r") if self._pos < len(self._buf) else None

    def push_back(self, data: bytes, n_lines: int) -> None:
        """Return *data* (whole lines, *n_lines* of them, just read) to the front of the stream."""
        self._buf = data + self._buf[self._pos:]
        self._pos = 0
        self.line_no -= n_lines

    def read_lines(self, n: int) -> tuple[bytes, int]:
        """Up to *n* following lines as one bytes block, and how many lines it holds (fewer at EOF)."""
        parts = []
        got = 0
        while got < n:
            if self._pos >= len(self._buf) and not self._fill():
                break
            view = np.frombuffer(self._buf, dtype=np.uint8, offset=self._pos)
            nl = np.flatnonzero(view == 10)
            need = n - got
            if nl.size >= need:
                end = self._pos + int(nl[need - 1]) + 1
                parts.append(self._buf[self._pos:end])
                self._pos = end
                got = n
                break
            if nl.size:
                end = self._pos + int(nl[-1]) + 1
                parts.append(self._buf[self._pos:end])
                got += nl.size
                self._pos = end
            if not self._fill():
                rest = self._buf[self._pos:]
                if rest.strip():
                    parts.append(rest + b"\n")
                    got += 1
                self._pos = len(self._buf)
                break
        self.line_no += got
        return b"".join(parts), got

    def read_chunk(self) -> tuple[bytes, int]:
        """The next run of whole lines (about CHUNK bytes) and the line number of its first line."""
        while True:
            k = self._buf.rfind(b"\n", self._pos)
            if k >= 0 and (k - self._pos > CHUNK // 2 or self._eof):
                break
            if not self._fill():
                k = len(self._buf) - 1
                break
        first = self.line_no + 1
        block = self._buf[self._pos:k + 1]
        if self._eof and k == len(self._buf) - 1 and block and not block.endswith(b"\n"):
            block += b"\n"
        self._pos = k + 1
        self.line_no += block.count(b"\n")
        return block, first


def block_values(block: bytes, n_lines: int, ncols: int | None, *, path, first_line: int,
                 what: str, allow_extra: bool = False) -> np.ndarray:
    """Parse *n_lines* lines of *ncols* numbers each into an ``(n_lines, ncols)`` array.

    ``ncols=None`` takes the column count of the first line. With ``allow_extra`` lines may carry more
    columns than used (only the first *ncols* are kept; slow path). Errors name the line.
    """
    if ncols is None:
        first = block.split(b"\n", 1)[0].split()
        ncols = len(first)
        if ncols == 0:
            raise ParseError(f"{what}: empty line where values were expected", path=path, line=first_line)
    vals = parse_floats(block)
    if vals is not None and vals.size == n_lines * ncols:
        out = vals.reshape(n_lines, ncols)
        if np.isfinite(out).all():
            return out
    return _block_values_slow(block, n_lines, ncols, path=path, first_line=first_line, what=what,
                              allow_extra=allow_extra)


def _block_values_slow(block, n_lines, ncols, *, path, first_line, what, allow_extra):
    lines = block.split(b"\n")
    # no more rows than the block has lines: a header count of 1e12 must not allocate before the first
    # missing line is reported
    out = np.empty((min(n_lines, len(lines)), ncols))
    for i in range(n_lines):
        lineno = first_line + i
        toks = lines[i].split() if i < len(lines) else []
        if len(toks) < ncols or (len(toks) > ncols and not allow_extra):
            text = as_text(lines[i], path, lineno).strip() if i < len(lines) else ""
            raise ParseError(f"{what}: expected {ncols} value(s), found {len(toks)} ({text[:60]!r})",
                             path=path, line=lineno)
        for j in range(ncols):
            try:
                v = float(toks[j])
            except ValueError:
                raise ParseError(f"{what}: non-numeric token {as_text(toks[j], path, lineno)[:40]!r}",
                                 path=path, line=lineno) from None
            if not np.isfinite(v):
                raise ParseError(f"{what}: value {as_text(toks[j], path, lineno)!r} is not finite",
                                 path=path, line=lineno)
            out[i, j] = v
    return out


def to_int(token, *, path, line: int, what: str) -> int:
    try:
        return int(token)
    except (ValueError, TypeError):
        try:
            f = float(token)
        except (ValueError, TypeError):
            f = float("nan")
        if np.isfinite(f) and f == int(f):
            return int(f)
        raise ParseError(f"{what}: expected an integer, found {token!r}", path=path, line=line) from None


def to_float(token, *, path, line: int, what: str) -> float:
    try:
        v = float(token)
    except (ValueError, TypeError):
        raise ParseError(f"{what}: expected a number, found {token!r}", path=path, line=line) from None
    if not np.isfinite(v):
        raise ParseError(f"{what}: value {token!r} is not finite", path=path, line=line)
    return v
