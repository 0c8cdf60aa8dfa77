"""The exclusive lock of a run directory: one process at a time starts, resumes, writes or replaces a run.

``RUN/run.lock`` holds an exclusive ``flock`` for as long as a command works on the run; the file
names its holder (process id, host, start time, command). The operating system releases a ``flock`` when its
process ends, however it ends (a ``kill -9`` included), so a lock can never outlive its process on the same
host; what outlives it is the lock file with the holder's record (a clean release removes the file).
Finding a record while taking a free lock therefore means the previous holder died without releasing it: ``RunLock.stale`` keeps that record
and the command reports it.

A second process asking for a held lock does not wait: :class:`RunLockedError` names the directory and the
holder. The lock is re-entrant within one process (the command line takes it before it checks the directory,
the run takes it again when it starts the manifest).

Why not the ``filelock`` package: its Unix lock opens the lock file with ``O_TRUNC`` before it tries the
lock, so every refused attempt would erase the holder's record that the refusal message and the stale-lock
report need; the ``flock`` it would wrap is a few lines of standard library.
"""
from __future__ import annotations

import json
import os
import socket
import sys
import threading
from datetime import datetime, timezone
from pathlib import Path

from ..errors import InputError

LOCK = "run.lock"

try:
    import fcntl
except ImportError:  # Windows: no flock; msvcrt.locking gives the same exclusive, non-blocking lock
    fcntl = None
    import msvcrt


class RunLockedError(InputError):
    """Another process holds the run directory's lock; names the directory and the holder."""

    def __init__(self, path, holder: dict | None):
        self.path = Path(path)
        self.holder = holder or {}
        super().__init__(f"{self.path} is in use by another breachflow process ({describe(self.holder)}); "
                         "wait for it to finish, or stop it, or use another --out directory")


def describe(holder: dict) -> str:
    """A holder record in words: ``pid 123 on host h, since 2026-11-27T20:00:00+00:00 (breachflow run ...)``."""
    if not holder:
        return "holder unknown"
    s = f"pid {holder.get('pid', '?')} on host {holder.get('host', '?')}"
    if holder.get("started"):
        s += f", since {holder['started']}"
    if holder.get("command"):
        s += f" ({holder['command']})"
    return s


def _record() -> dict:
    return {"pid": os.getpid(), "host": socket.gethostname(),
            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])[:300] if sys.argv else ""}


def _read_record(fd: int) -> dict:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        raw = os.read(fd, 65536)
    except OSError:
        return {}
    if not raw.strip():
        return {}
    try:
        rec = json.loads(raw.decode("utf-8", "replace"))
        return rec if isinstance(rec, dict) else {"record": str(rec)}
    except ValueError:
        return {"record": raw[:200].decode("utf-8", "replace")}


def read_holder(path) -> dict:
    """The record in a run directory's lock file (``{}`` when there is none); it names the holder while the
    lock is held, and a holder that died without releasing it when it is not."""
    try:
        fd = os.open(Path(path) / LOCK, os.O_RDONLY)
    except OSError:
        return {}
    try:
        return _read_record(fd)
    finally:
        os.close(fd)


def pid_alive(pid) -> bool:
    """Whether process *pid* exists on this host."""
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except (PermissionError, ValueError, TypeError, OverflowError):
        return True
    return True


def _try_lock(fd: int) -> bool:
    if fcntl is not None:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            return False
    try:  # pragma: no cover - Windows
        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        return True
    except OSError:
        return False


def _unlock(fd: int) -> None:
    if fcntl is not None:
        fcntl.flock(fd, fcntl.LOCK_UN)
    else:  # pragma: no cover - Windows
        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)


_held: dict[str, "RunLock"] = {}  #: locks this process holds, by resolved directory
_guard = threading.Lock()


class RunLock:
    """``with RunLock(path):`` — hold the exclusive lock of run directory *path* (created if need be).

    Raises :class:`RunLockedError` at once when another process holds it. After entering, ``stale`` is
    the record of a previous holder that died without releasing the lock (``{}`` when there was none) and
    ``created_dir`` tells whether the directory was made for this lock. On leaving, the lock file is
    removed, and the directory too when it was made for the lock and nothing else was written into it (a
    refused scenario leaves nothing behind). A process that opened the old file and locks it after that
    removal sees that the file it locked is no longer the directory's lock file and tries again.
    """

    def __init__(self, path):
        self.path = Path(path)
        self.fd: int | None = None
        self.depth = 0
        self.stale: dict = {}
        self.created_dir = False

    @property
    def file(self) -> Path:
        return self.path / LOCK

    def acquire(self) -> "RunLock":
        key = str(self.path.resolve())
        with _guard:
            other = _held.get(key)
            if other is not None and other is not self:  # re-entrant within the process: share the holder's
                other.depth += 1
                self._outer = other
                self.stale, self.created_dir = other.stale, other.created_dir
                return self
            if self.fd is not None:
                self.depth += 1
                return self
            self.created_dir = not self.path.exists()
            self.path.mkdir(parents=True, exist_ok=True)
            while True:
                fd = os.open(self.file, os.O_RDWR | os.O_CREAT, 0o666)
                if not _try_lock(fd):
                    holder = _read_record(fd)
                    os.close(fd)
                    raise RunLockedError(self.path, holder)
                # the file may have been removed (by a holder cleaning up an empty directory) between our
                # open and our lock: then we hold a lock nobody else can see; open the new file and retry
                try:
                    same = os.fstat(fd).st_ino == os.stat(self.file).st_ino
                except FileNotFoundError:
                    same = False
                if same:
                    break
                os.close(fd)
                self.path.mkdir(parents=True, exist_ok=True)
            self.stale = _read_record(fd)
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.write(fd, (json.dumps(_record()) + "\n").encode())
            os.fsync(fd)
            self.fd, self.depth = fd, 1
            _held[key] = self
            return self

    def release(self) -> None:
        with _guard:
            outer = getattr(self, "_outer", None)
            if outer is not None:
                outer.depth -= 1
                self._outer = None
                return
            if self.fd is None:
                return
            self.depth -= 1
            if self.depth > 0:
                return
            _held.pop(str(self.path.resolve()), None)
            fd, self.fd = self.fd, None
            try:
                # a clean release leaves no lock file: a file with a record means its holder died holding it
                os.ftruncate(fd, 0)
                self.file.unlink(missing_ok=True)
                if self.created_dir:
                    try:
                        self.path.rmdir()  # only when empty: a refused scenario leaves nothing behind
                    except OSError:
                        pass
            finally:
                _unlock(fd)
                os.close(fd)

    def __enter__(self) -> "RunLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def held_by_me(path) -> bool:
    """Whether this process holds the lock of run directory *path*."""
    with _guard:
        return str(Path(path).resolve()) in _held
