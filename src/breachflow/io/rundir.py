"""A run directory: one CF NetCDF file per completed cycle, a restart file, and a manifest.

Layout::

    RUN/manifest.json                  what the run is (scenario text + hash, seed) and which cycles are complete
    RUN/cycle_0001.nc                  hydrodynamic grid + particle states at equilibrium (CF-1.8)
    RUN/trajectories_0001.nc           trajectories of the cycle's moving particles (CF DSG trajectory)
    RUN/restart_0001.npz               everything needed to continue bit-identically from this cycle

    RUN/scenario.toml                  the scenario text the run was started with (``--resume`` reads it)
    RUN/run.log                        what the console showed, plus warnings (appended by every session)
    RUN/run.lock                       the exclusive lock of the process working on the run (:mod:`.lock`)

Every file is written atomically, and the manifest — rewritten atomically *after* a cycle's files —
is the commit point: a crash leaves at worst stray temp files or files of a cycle the manifest does not
list, which resuming sweeps away (:meth:`RunDirectory.sweep`). Every change is made under the directory's
exclusive lock (:class:`~breachflow.io.lock.RunLock`, taken by :meth:`RunDirectory.start` when the caller
does not hold it yet), committed cycles are numbered 1, 2, ... without gaps, and a manifest carries a
``run_id``: a process writes only into the run it started or resumed. :meth:`RunDirectory.verify` checks
the whole directory (docs/run-safety.md). The manifest records the provenance
(:func:`breachflow.provenance.attrs`) of the command that started the run and of every resume.

Each cycle file carries a length-1 ``cycle`` dimension coordinate on its per-cycle variables, its
particles padded to the run's capacity (``max_cycles × batch``: the same ``particle`` index in every
cycle), and the steady-state history of its solve, whose length varies, in the NetCDF group
``convergence_history``; so ``xr.open_mfdataset("RUN/cycle_*.nc")`` stacks the cycles. Format 1 (before 2026-11) named the trajectory files ``cycle_NNNN_trajectories.nc`` (caught by that
glob) and had no ``cycle`` dimension; such directories still resume and combine — file names are taken
from the manifest — and new cycles are written in the current layout.
"""
from __future__ import annotations

import hashlib
import io
import json
import re
import uuid
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from .. import provenance
from ..atomic import atomic_write, atomic_write_json, atomic_write_netcdf, atomic_write_text
from .cf import netcdf_encoding
from .cycle_variables import cycle_coordinate
from .lock import LOCK, RunLock, held_by_me

MANIFEST = "manifest.json"
#: the steady-state history of a cycle's solve: a dimension whose length varies from cycle to cycle,
#: so it lives in its own NetCDF group of the cycle file
HISTORY_DIM, HISTORY_GROUP = "convergence_check", "convergence_history"
FORMAT_VERSION = 2
SCENARIO = "scenario.toml"
#: manifest ``metadata`` keys of runs written by earlier versions, and their current names: a resumed
#: old run is read under the current names (``nested_window`` was the nested grid's box)
RENAMED_METADATA = {"nested_window": "nested_box"}
LOG = "run.log"
#: temp files of :func:`~.atomic.atomic_path`: ``.NAME.XXXXXXXX.SUFFIX`` (mkstemp's 8 random characters)
_TEMP = re.compile(r"^\.(?P<target>.+)\.[A-Za-z0-9_]{8}\.[A-Za-z0-9]+$")
_CYCLE_FILE = re.compile(r"^(cycle|restart|trajectories)_(?P<g>\d{4})(_trajectories)?\.(nc|npz)$")


def session(action: str) -> dict:
    """A manifest record of one command acting on a run: time, action and :func:`breachflow.provenance.attrs`."""
    return {"time": datetime.now(timezone.utc).isoformat(timespec="seconds"), "action": action,
            **provenance.attrs()}


def scenario_hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def file_sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


class RunDirectory:
    """Create, resume and read a closure run's directory (see module docstring)."""

    def __init__(self, path):
        self.path = Path(path)
        self.swept: list[Path] = []  #: files :meth:`sweep` removed when the run was resumed
        self.run_id: str | None = None  #: the ``run_id`` of the run this object started or resumed
        self._lock: RunLock | None = None
        #: the record of a process that died holding the directory's lock (``{}``: none), found by :meth:`start`
        self.stale_lock: dict = {}

    # ----------------------------------------------------------------- lock
    def lock(self) -> RunLock:
        """The directory's exclusive lock (``with rd.lock(): ...``; re-entrant within a process)."""
        return RunLock(self.path)

    def _hold_lock(self) -> None:
        """Take the directory's lock for the life of this object unless this process holds it already."""
        if self._lock is None:
            self._lock = self.lock().acquire()
            self.stale_lock = self._lock.stale

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def close(self) -> None:
        """Release the lock :meth:`start` took (a no-op when the caller holds the lock itself)."""
        if self._lock is not None:
            lock, self._lock = self._lock, None
            lock.release()

    def _check_owner(self, man: dict) -> None:
        """Refuse to write into a manifest of another run than the one this object started or resumed."""
        if self.run_id is not None and man.get("run_id") != self.run_id:
            raise InputError(f"{self.path}: the run was replaced by another process (run_id "
                             f"{man.get('run_id')!r}, this process's {self.run_id!r}); stopping without writing")

    # ----------------------------------------------------------------- manifest
    @property
    def manifest_path(self) -> Path:
        return self.path / MANIFEST

    def manifest(self) -> dict:
        """The manifest; metadata keys of earlier versions under their current names (:data:`RENAMED_METADATA`)."""
        try:
            man = json.loads(self.manifest_path.read_text())
        except FileNotFoundError:
            raise InputError(f"{self.path}: not a breachflow run directory (no {MANIFEST})") from None
        except json.JSONDecodeError as exc:
            raise InputError(f"{self.manifest_path}: corrupt manifest ({exc})") from None
        meta = man.get("metadata") if isinstance(man, dict) else None
        if isinstance(meta, dict):
            for old, new in RENAMED_METADATA.items():
                if old in meta and new not in meta:
                    meta[new] = meta.pop(old)
        return man

    def exists(self) -> bool:
        return self.manifest_path.exists()

    def start(self, scenario_text: str, *, seed: int, resume: bool = False, overwrite: bool = False,
              metadata: dict | None = None) -> dict:
        """Begin a run, or check that *resume* continues the same scenario; returns the manifest.

        A new run in a directory holding another run is refused unless *overwrite*. The directory's lock is
        taken first (:class:`~breachflow.io.lock.RunLockedError` when another process holds it) and kept
        until :meth:`close` unless the caller holds it already.
        """
        digest = scenario_hash(scenario_text)
        self.swept: list[Path] = []
        self._hold_lock()
        action = "start"
        if self.exists():
            man = self.manifest()
            if resume:
                if man["scenario_sha256"] != digest or man["seed"] != seed:
                    raise InputError(
                        f"{self.path}: cannot resume: the run was started with another scenario or seed "
                        f"(scenario sha256 {man['scenario_sha256'][:12]}…, seed {man['seed']})")
                self._check_continuity(man)
                self.swept = self.sweep()
                man.setdefault("run_id", uuid.uuid4().hex)
                self.run_id = man["run_id"]
                man.setdefault("sessions", []).append(session("resume"))
                atomic_write_json(man, self.manifest_path)
                return man
            if not overwrite:
                raise InputError(f"{self.path}: holds a run already; use resume or overwrite")
            # the old manifest goes first: a crash from here on leaves a directory without a run (a new run
            # starts there), never a manifest that lists files of the old run beside the new one's
            self.manifest_path.unlink()
            for p in [*self.path.glob("cycle_*.nc"), *self.path.glob("trajectories_*.nc"),
                      *self.path.glob("restart_*.npz")]:
                p.unlink()
            self.swept = self.sweep()
            action = "overwrite"
        elif resume:
            raise InputError(f"{self.path}: nothing to resume (no {MANIFEST})")
        else:
            self.swept = self.sweep()  # cycle files of a run whose manifest never got written
        self.path.mkdir(parents=True, exist_ok=True)
        atomic_write_text(scenario_text, self.path / SCENARIO)
        self.run_id = uuid.uuid4().hex
        man = {
            "format_version": FORMAT_VERSION,
            "run_id": self.run_id,
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "scenario_sha256": digest,
            "seed": int(seed),
            "metadata": metadata or {},
            "provenance": provenance.attrs(),
            "sessions": [session(action)],
            "cycles": [],
            "finished": False,
        }
        atomic_write_json(man, self.manifest_path)
        return man

    def _check_continuity(self, man: dict) -> None:
        nums = [c.get("cycle") for c in man.get("cycles", [])]
        if nums != list(range(1, len(nums) + 1)):
            raise InputError(f"{self.manifest_path}: committed cycles {nums} are not 1, 2, ... without gaps; "
                             "the run directory is damaged (--overwrite starts it again)")

    def sweep(self) -> list[Path]:
        """Remove what a killed run can leave behind: temp files of interrupted atomic writes and cycle or
        restart files of cycles the manifest does not list. Returns the removed paths."""
        last = self.last_cycle() if self.exists() else 0
        if not held_by_me(self.path):
            raise InputError(f"{self.path}: sweeping a run directory needs its lock (RunDirectory.lock())")
        gone = []
        for p in sorted(self.path.iterdir()) if self.path.is_dir() else []:
            m = _CYCLE_FILE.match(p.name)
            if (_TEMP.match(p.name) and p.is_file()) or (m and int(m.group("g")) > last):
                p.unlink(missing_ok=True)
                gone.append(p)
        return gone

    def scenario_text(self) -> str:
        """The scenario text the run was started with (``RUN/scenario.toml``)."""
        try:
            return (self.path / SCENARIO).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise InputError(f"{self.path}: no {SCENARIO} in the run directory") from None

    def completed_cycles(self) -> list[int]:
        return [c["cycle"] for c in self.manifest()["cycles"]]

    def last_cycle(self) -> int:
        done = self.completed_cycles()
        return done[-1] if done else 0

    # ----------------------------------------------------------------- cycles
    def cycle_path(self, g: int) -> Path:
        return self.path / f"cycle_{g:04d}.nc"

    def trajectories_path(self, g: int) -> Path:
        """Where cycle *g*'s trajectories are written (not matched by the glob ``cycle_*.nc``)."""
        return self.path / f"trajectories_{g:04d}.nc"

    def committed_file(self, g: int, kind: str) -> Path | None:
        """The file of *kind* (``field``, ``trajectories``, ``restart``) the manifest lists for cycle *g*
        (older run directories used other names), or None."""
        for c in self.manifest()["cycles"]:
            if c["cycle"] == g:
                name = c["files"].get(kind)
                return self.path / name if name else None
        return None

    def restart_path(self, g: int) -> Path:
        return self.path / f"restart_{g:04d}.npz"

    def write_cycle(self, g: int, field: xr.Dataset, trajectories: xr.Dataset | None, restart: dict,
                    summary: dict) -> None:
        """Write cycle *g*'s files atomically, then commit it to the manifest."""
        self._hold_lock()
        man = self.manifest()
        self._check_owner(man)
        last = man["cycles"][-1]["cycle"] if man["cycles"] else 0
        if g != last + 1:
            raise InputError(f"{self.path}: cannot commit cycle {g}: "
                             + (f"it does not follow the last complete cycle {last} (the next is {last + 1})" if last
                                else "no cycle is complete yet; the first cycle is 1"))
        files = {}
        hist_vars = [v for v in field.data_vars if HISTORY_DIM in field[v].dims]
        root, hist = provenance.stamp(field.drop_vars(hist_vars)), field[hist_vars]

        def write_field(tmp):
            root.to_netcdf(tmp, engine="netcdf4", encoding=netcdf_encoding(root))
            if hist_vars:
                hist.to_netcdf(tmp, mode="a", group=HISTORY_GROUP, engine="netcdf4", encoding=netcdf_encoding(hist))

        atomic_write(self.cycle_path(g), write_field)
        files["field"] = self.cycle_path(g).name
        if trajectories is not None:
            atomic_write_netcdf(trajectories, self.trajectories_path(g), encoding=netcdf_encoding(trajectories))
            files["trajectories"] = self.trajectories_path(g).name

        def write_npz(tmp):
            buf = io.BytesIO()
            np.savez(buf, **restart)
            Path(tmp).write_bytes(buf.getvalue())

        atomic_write(self.restart_path(g), write_npz)
        files["restart"] = self.restart_path(g).name
        entry = {"cycle": int(g), "files": files,
                 "sha256": {k: file_sha256(self.path / v) for k, v in files.items()},
                 "completed": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                 "summary": summary}
        man["cycles"].append(entry)
        atomic_write_json(man, self.manifest_path)
        # a previous crashed attempt may have left restart files of later cycles: they are not committed
        for p in self.path.glob("restart_*.npz"):
            if int(p.stem.split("_")[1]) > g:
                p.unlink()

    def update_metadata(self, **items) -> None:
        """Merge *items* into the manifest's ``metadata`` (atomically)."""
        self._hold_lock()
        man = self.manifest()
        self._check_owner(man)
        man.setdefault("metadata", {}).update(items)
        atomic_write_json(man, self.manifest_path)

    def finish(self, summary: dict) -> None:
        self._hold_lock()
        man = self.manifest()
        self._check_owner(man)
        man["finished"] = True
        man["final"] = summary
        atomic_write_json(man, self.manifest_path)

    def load_restart(self, g: int) -> dict:
        with np.load(self.restart_path(g), allow_pickle=False) as data:
            return {k: data[k] for k in data.files}

    def verify(self) -> list[str]:
        """Check the whole directory; returns the list of problems (empty when intact): the manifest reads,
        its cycles are 1, 2, ... without gaps, every committed file is there with its checksum, no cycle,
        trajectory or restart file lies there that the manifest does not list, no temp file of an interrupted
        write is left, ``scenario.toml`` is the scenario the manifest records, and a finished run's final
        record names its last cycle."""
        try:
            man = self.manifest()
        except InputError as exc:
            return [str(exc)]
        problems = []
        nums = [c.get("cycle") for c in man.get("cycles", [])]
        if nums != list(range(1, len(nums) + 1)):
            problems.append(f"{self.manifest_path}: committed cycles {nums} are not 1, 2, ... without gaps")
        listed = set()
        for c in man.get("cycles", []):
            for kind, name in c["files"].items():
                listed.add(name)
                p = self.path / name
                if not p.exists():
                    problems.append(f"{p}: missing")
                elif file_sha256(p) != c["sha256"][kind]:
                    problems.append(f"{p}: checksum mismatch")
        for p in sorted(self.path.iterdir()):
            if p.name in listed or p.name == LOCK:
                continue
            if _CYCLE_FILE.match(p.name):
                problems.append(f"{p}: not in the manifest (a cycle file of no committed cycle)")
            elif _TEMP.match(p.name):
                problems.append(f"{p}: temp file left by an interrupted write")
        sc = self.path / SCENARIO
        if not sc.exists():
            problems.append(f"{sc}: missing")
        elif scenario_hash(sc.read_text(encoding="utf-8")) != man.get("scenario_sha256"):
            problems.append(f"{sc}: not the scenario the manifest records (sha256 "
                            f"{str(man.get('scenario_sha256'))[:12]}…)")
        if man.get("finished") and nums and man.get("final", {}).get("cycles", nums[-1]) != nums[-1]:
            problems.append(f"{self.manifest_path}: finished after cycle {man['final']['cycles']} but the last "
                            f"committed cycle is {nums[-1]}")
        return problems

    # ----------------------------------------------------------------- archive
    def open_cycle(self, g: int, **kwargs) -> xr.Dataset:
        """Cycle *g*'s grid and particle states, loaded, without the file's length-1 ``cycle`` dimension."""
        path = self.committed_file(g, "field") or self.cycle_path(g)
        with xr.open_dataset(path, **kwargs) as ds:
            ds = ds.load()
        try:
            with xr.open_dataset(path, group=HISTORY_GROUP, **kwargs) as hist:
                ds = ds.merge(hist.load(), combine_attrs="override")
        except OSError:  # no such group: no history (or a format-1 file holding it in the root group)
            pass
        return squeeze_cycle(ds)

    def combine(self, out) -> Path:
        """Combine all complete cycles into one NetCDF archive readable with ``xr.open_dataset``.

        The root group holds the per-cycle grids stacked along ``cycle`` and the final particle states;
        the group ``trajectories`` holds every cycle's trajectories concatenated (with their cycle).
        """
        cycles = self.completed_cycles()
        if not cycles:
            raise InputError(f"{self.path}: no complete cycle to combine")
        fields = []
        for g in cycles:
            fields.append(self.open_cycle(g, decode_times=False))
        # the grid mapping is one variable of the archive (no cycle dimension: CF §5.6)
        static = [v for v in fields[-1].data_vars if v == "crs"]
        grid_vars = [v for v in fields[-1].data_vars if "particle" not in fields[-1][v].dims and v not in static]
        grids = _pad_to_common_sizes([f[grid_vars] for f in fields])
        stacked = xr.concat(grids, dim="cycle", data_vars="all", coords="minimal",
                            compat="override", join="override")
        stacked = stacked.assign_coords(cycle=cycle_coordinate(cycles))
        for v in static:
            stacked[v] = fields[-1][v]
        last = fields[-1]
        part_vars = [v for v in last.data_vars if "particle" in last[v].dims]
        final = last[part_vars]
        if "particle_placed_cycle" in final:  # drop the padding of not-yet-placed entries
            final = final.isel(particle=np.flatnonzero(final.particle_placed_cycle.values > 0))
            for v in ("particle_active", "particle_resting"):
                if v in final and -1 in np.asarray(final[v].attrs.get("flag_values", [])):
                    final[v].attrs["flag_values"] = final[v].attrs["flag_values"][1:]
                    final[v].attrs["flag_meanings"] = final[v].attrs["flag_meanings"].removeprefix("not_placed ")
        archive = xr.merge([stacked, final], combine_attrs="override")
        archive.attrs = dict(last.attrs)
        archive.attrs["title"] = "breachflow closure run archive"
        archive.attrs["cycles"] = f"{cycles[0]}..{cycles[-1]}"
        archive = provenance.stamp(archive)
        out = Path(out)
        atomic_write_netcdf(archive, out, provenance=False, encoding=netcdf_encoding(archive))
        trajs = []
        for g in cycles:
            p = self.committed_file(g, "trajectories")
            if p is not None and p.exists():
                with xr.open_dataset(p, decode_times=False) as t:
                    t = t.load()
                t["trajectory_cycle"] = ("trajectory", np.full(t.sizes["trajectory"], g, "i4"),
                                         {"long_name": "cycle <g> of the trajectory", "units": "1"})
                trajs.append(t)
        if trajs:
            trajs = _pad_to_common_sizes(trajs, dims=("obs",))
            tr = xr.concat(trajs, dim="trajectory", combine_attrs="override")
            tr.attrs["title"] = "breachflow trajectories of all cycles"
            tr.attrs.pop("cycle", None)
            tr = provenance.stamp(tr)
            # append the group to the archive just written (still atomic: rewrite via temp copy)
            def write_both(tmp):
                archive.to_netcdf(tmp, engine="netcdf4", encoding=netcdf_encoding(archive))
                tr.to_netcdf(tmp, mode="a", group="trajectories", engine="netcdf4", encoding=netcdf_encoding(tr))

            atomic_write(out, write_both)
        return out


def squeeze_cycle(ds: xr.Dataset) -> xr.Dataset:
    """A cycle file's Dataset without its length-1 ``cycle`` dimension and the per-cycle index coordinates
    (format 1 files, which have neither, pass unchanged)."""
    if "cycle" in ds.dims:
        ds = ds.isel(cycle=0, drop=True)
    return ds


def _pad_to_common_sizes(datasets, dims=None):
    """Pad (with fill values at the end) the dimensions that differ between *datasets* — the per-cycle
    steady-state history, the observations of trajectories — so that they stack; *dims* limits which."""
    sizes = {}
    for ds in datasets:
        for d, n in ds.sizes.items():
            if (dims is None or d in dims) and d not in ds.indexes:
                sizes[d] = max(sizes.get(d, 0), n)
    out = []
    for ds in datasets:
        pad = {d: (0, n - ds.sizes[d]) for d, n in sizes.items() if d in ds.sizes and ds.sizes[d] < n}
        out.append(ds.pad(pad) if pad else ds)
    return out
