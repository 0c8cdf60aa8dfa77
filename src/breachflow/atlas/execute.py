"""Running a breach atlas on dask.distributed: a local cluster or an existing scheduler, resumable.

Output directory::

    OUT/district.toml                 the district file as run
    OUT/locations/<NNNN>.json         one record per candidate location (written atomically by the worker)
    OUT/atlas.nc                      every location along ``location`` (CF, the district's CRS)
    OUT/atlas.gpkg                    layer ``breach_atlas``: one levee reach per location with its figures
    OUT/atlas.png                     the levee coloured by closure feasibility

A record carries a key that hashes the district file's text and the location: a rerun into the same
directory (resume, the default) reuses exactly the records whose inputs are unchanged. Each location is
computed alone, single-threaded and deterministically, so the results do not depend on the number of
workers or on the order they finish in; a task whose worker dies is run again by dask's scheduler on
another worker (``distributed.scheduler.allowed-failures``).
"""
from __future__ import annotations

import hashlib
import json
import time
from dataclasses import asdict
from pathlib import Path

from ..errors import InputError
from ..atomic import atomic_write_json, atomic_write_text
from .config import District, load_district
from .locations import Location, load_inputs as _inputs, locate

RECORD_FORMAT = "breachflow.atlas.location/1"


def plan(district: District | str | Path) -> tuple[District, list[Location]]:
    """The district (parsed) and its candidate locations with their levee sections."""
    if not isinstance(district, District):
        district = load_district(district)
    terrain, levee = _inputs(str(district.terrain), str(district.levee), district.crs, district.terrain_units)
    return district, locate(levee, terrain, spacing=district.spacing, points=district.points, margin=district.margin,
                            flood_side=district.flood_side)




def location_key(district: District, loc: Location) -> str:
    text = district.path.read_text() if district.path is not None else repr(district)
    from .. import __version__
    from .screening import FIELDS

    h = hashlib.sha256(text.encode())
    h.update(f"{__version__} {RECORD_FORMAT} {sorted(FIELDS)}".encode())
    h.update(json.dumps(loc.as_dict(), sort_keys=True).encode())
    return h.hexdigest()[:20]


def screen_location(district: District, loc: Location, record_path: str, key: str) -> dict:
    """Screen one location and write its record atomically; a failure is recorded, not raised."""
    from .screening import screen

    t0 = time.perf_counter()
    rec = {"format": RECORD_FORMAT, "key": key, "location": loc.as_dict()}
    try:
        terrain, levee = _inputs(str(district.terrain), str(district.levee), district.crs, district.terrain_units)
        rec["result"] = screen(loc, district, terrain=terrain, levee=levee)
    except Exception as exc:  # one location's failure must not stop the atlas
        rec["result"] = {"status": "failed", "message": f"{type(exc).__name__}: {exc}"}
    rec["elapsed_s"] = time.perf_counter() - t0
    atomic_write_json(rec, record_path)
    return rec


def run_atlas(district, out, *, scheduler: str | None = None, workers: int | None = None, client=None,
              resume: bool = True, progress: bool = True, console=None, write: bool = True,
              detailed: bool | None = None):
    """Screen every candidate location of a district and write the atlas; returns its Dataset.

    *district*: a path or a :class:`~breachflow.atlas.config.District`. *out*: the output directory.
    Execution: an existing dask *client*, a *scheduler* address (``tcp://host:8786``) or scheduler file
    (``*.json``), or a local cluster of *workers* processes (default: one per core). *resume*: reuse the
    records of an earlier run into *out* whose inputs are unchanged. *detailed*: run the detailed tier
    (:mod:`breachflow.atlas.detailed`; default: when the district file has a ``[detailed]`` table).
    """
    from rich.console import Console

    from .outputs import build_dataset, write_outputs

    console = console or Console(stderr=True)
    district, locations = plan(district)
    if detailed is None:
        detailed = district.detailed is not None
    if detailed and district.detailed is None:
        raise InputError("the detailed tier needs a [detailed] table in the district file (worst, replicates, "
                         "scenario)")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")
    rec_dir = out / "locations"
    rec_dir.mkdir(parents=True, exist_ok=True)
    if district.path is not None:
        atomic_write_text(district.path.read_text(), out / "district.toml")
    records: list[dict | None] = [None] * len(locations)
    keys = [location_key(district, loc) for loc in locations]
    paths = [rec_dir / f"{loc.index:04d}.json" for loc in locations]
    if resume:
        for i, p in enumerate(paths):
            try:
                rec = json.loads(p.read_text())
            except (OSError, ValueError):
                continue
            if rec.get("format") == RECORD_FORMAT and rec.get("key") == keys[i]:
                records[i] = rec
    pending = [i for i, r in enumerate(records) if r is None]
    console.print(f"atlas [bold]{district.name}[/]: {len(locations)} locations along {_length(district):.1f} km "
                  f"at {district.spacing:g} m" + (f", {len(locations) - len(pending)} done earlier (resume)"
                                                 if len(pending) < len(locations) else ""), highlight=False)
    # one client (and local cluster) for both tiers, started only when something is to be computed
    own_client = own_cluster = None
    try:
        if client is None and (pending or detailed):
            own_client, own_cluster = _client_for(scheduler, workers)
            client = own_client
            workers = None if own_cluster is not None else workers
        if pending:
            _execute(district, locations, keys, paths, pending, records, client=client, progress=progress,
                     console=console)
        ds = build_dataset(district, locations, records)
        if detailed:
            from .detailed import run_detailed

            ds = run_detailed(district, ds, locations, out, client=client, workers=workers, progress=progress,
                              console=console)
    finally:
        from ..ensemble.execute import close_own

        close_own(own_client, own_cluster)
    if write:
        for p in write_outputs(ds, district, locations, out):
            console.print(f"wrote {p}", highlight=False)
    return ds


def _length(district: District) -> float:
    _, levee = _inputs(str(district.terrain), str(district.levee), district.crs, district.terrain_units)
    return levee.length / 1000.0


def _client_for(scheduler: str | None, workers: int | None):
    """(client, cluster, restrict): a client on *scheduler* (address or scheduler file) or a local cluster."""
    from distributed import Client

    from ..ensemble.execute import local_cluster

    if scheduler:
        if scheduler.endswith(".json"):
            return Client(scheduler_file=scheduler), None
        return Client(scheduler), None
    cluster = local_cluster(workers)
    return Client(cluster), cluster


def _execute(district, locations, keys, paths, pending, records, *, client, progress, console) -> None:
    from distributed import as_completed

    from ..progress import Progress

    n = len(client.scheduler_info()["workers"])
    console.print(f"dask scheduler {client.scheduler.address}, {n} worker(s)", highlight=False)
    futures = client.map(screen_location, [district] * len(pending), [locations[i] for i in pending],
                         [str(paths[i]) for i in pending], [keys[i] for i in pending],
                         key=[f"atlas-screen-{keys[i]}" for i in pending], pure=False, retries=1)
    index = dict(zip(futures, pending))
    failed = 0
    with Progress("screening locations", total=len(pending), console=console, unit="locations",
                  quiet=not progress) as bar:
        for fut in as_completed(futures):
            i = index.pop(fut)
            try:
                rec = fut.result()
            except Exception as exc:  # the task could not run at all (e.g. a worker died twice)
                rec = {"format": RECORD_FORMAT, "key": keys[i], "location": locations[i].as_dict(),
                       "result": {"status": "failed", "message": f"{type(exc).__name__}: {exc}"}}
            fut.release()
            records[i] = rec
            failed += rec["result"].get("status") == "failed"
            bar.update(advance=1, note=f"{failed} failed" if failed else "")
