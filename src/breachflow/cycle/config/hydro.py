"""The ``[hydro]`` section: the flow solver of a closure run, its resolution and steady-state tolerance,
the warm re-solve (full domain or a region) and the nested fine grid (docs/theory.md, *Shallow-water equations*)."""
from __future__ import annotations

from dataclasses import dataclass, field

from ...scenario.config import register_section
from ...swe.solver import WINDOW_CHANGE


#: warm re-solve of the ``swe`` solver: whole domain, or a region around the changed cells
#: (:mod:`breachflow.hydro.resolve_region`)
RESOLVE_MODES = ("full", "region")
#: deprecated spellings: ``[hydro] window`` is ``nested_box``, ``resolve = "window"`` is ``"region"``
RENAMED_KEYS = {"window": "nested_box"}
RENAMED_RESOLVE = {"window": "region"}

#: solvers that take ingested snapshot files
SNAPSHOT_SOLVERS = ("snapshot", "snapshot_frozen", "nested")


@register_section("hydro")
@dataclass
class HydroSection:
    """``[hydro]``: ``solver`` (``swe`` | ``nested`` | ``snapshot_frozen`` | a plug-in; ``snapshot`` is the
    deprecated name of ``snapshot_frozen``), ``resolution``, ``order``, ``courant``,
    ``tolerance`` (relative rate, 1/s, of depth and discharge near the breach and of the breach
    discharge), ``t_max_initial`` / ``t_max`` (simulated time of the first and of each warm-started
    solve), ``monitor_radius`` (steady state is judged within this distance of the breach),
    ``snapshots`` (files for the ``snapshot_frozen`` / ``nested`` solvers: snapshot NetCDF from ``breachflow
    ingest``; ``nested`` also takes the model's own export files forming one snapshot — ADH ``.3dm`` +
    ``.dat`` + ``.bc``, a HEC-RAS ``.sdf`` or 6.x plan ``.hdf`` — read with ``open_snapshot``), ``nested_box``
    (``[x0, x1, y0, y1]`` of the ``nested`` local model, formerly ``window``; default the breach ± (B/2 + 3 B) along the levee,
    ± 3 B across), ``threads`` (numba threads of one solve; default 1, the least CPU time; more threads
    can cut its wall time on free cores, docs/performance.md, *Shallow water against ANUGA*). The default 2e-4 1/s puts the warm re-solves of the default scene within 0.37 % of
    their steady breach discharge (the former 2e-3 1/s and 60 s: 2.71 %; issue 12,
    ``python3 tasks.py bench steady``).

    ``resolve`` (``full`` | ``region``, formerly ``window``): a warm re-solve of the ``swe`` solver over the
    whole domain, or only in a region around the cells the remap changed, ``resolve_margin`` (default 2 B) beyond them and
    the breach, the rest frozen at the previous steady state, grown when the water level at its edge moves
    by more than ``resolve_edge_level`` (:mod:`breachflow.hydro.resolve_region`); ``resolve_far`` (``frozen`` |
    ``coarse``, :mod:`breachflow.hydro.far_field`) how the domain outside the region follows the pile,
    ``resolve_far_factor`` the coarsening of ``coarse`` (default 2). ``steady_average`` (default false): the
    ``swe`` solves (cold, warm, region) also accept the running mean of the breach discharge when its
    batch-means error is within the tolerance (``run_to_steady(average=True)``,
    :mod:`breachflow.swe.steady_mean`; the state is then the time mean). ``refine`` (a length, with
    ``solver = "swe"``): a nested fine grid of that cell size around the breach (``nested_box``, default the
    breach ± (B/2 + 3 B) along the levee, ± 3 B across) inside the coarse domain at ``resolution``: the
    coarse open-breach steady state is solved once and is the regional field of the ``nested`` local model
    (:mod:`breachflow.hydro.nested`) the closure runs on. ``cold_start`` (``cold`` | ``coarse``): the first
    ``swe`` solve from the initial state on the run's grid, or from the steady state of a grid twice as
    coarse (:mod:`breachflow.hydro.coarse_start`; docs/verdict-check.md). ``steady_window`` (a time, ``"auto"``
    — one long-wave crossing of the domain along the flow through the breach, :meth:`~breachflow.swe.solver.SWESimulation.crossing_time`
    — or ``"0 s"``: off; default ``"auto"``) and ``steady_window_change`` (default 0.01, :data:`~breachflow.swe.solver.WINDOW_CHANGE`): a ``swe`` solve is
    steady only after marching at least the window, with the breach discharge within that relative range over
    its last window (``run_to_steady(window=...)``; docs/verdict-check.md, *Re-solves that settle*)."""

    solver: str = "swe"
    resolution: float = 1.0
    order: int = 2
    courant: float = 0.45
    tolerance: float = 2e-4
    t_max_initial: float = 300.0
    t_max: float = 300.0
    monitor_radius: float = 20.0
    snapshots: list = field(default_factory=list)
    nested_box: tuple | None = None
    threads: int = 1
    resolve: str = "full"
    resolve_margin: float | None = None
    resolve_edge_level: float = 0.03
    resolve_far: str = "frozen"
    resolve_far_factor: int = 2
    refine: float | None = None
    steady_average: bool = False
    cold_start: str = "cold"
    steady_window: float | str = "auto"
    steady_window_change: float = WINDOW_CHANGE

    @classmethod
    def extra_schema_keys(cls) -> dict:
        """``steady_window``: a time or ``"auto"``."""
        from ...scenario.reference import quantity_schema

        return {"steady_window": {"anyOf": [quantity_schema("time", nonnegative=True), {"const": "auto"}],
                                  "default": "auto"}}

    @classmethod
    def from_table(cls, table, ctx):
        for old, new in RENAMED_KEYS.items():
            table = ctx.renamed(table, old, new)
        table = ctx.renamed(table, "resolve", values=RENAMED_RESOLVE)
        ctx.check_keys(table, {"solver", "resolution", "order", "courant", "tolerance", "t_max_initial", "t_max",
                               "monitor_radius", "snapshots", "nested_box", "threads", "resolve", "resolve_margin",
                               "resolve_edge_level", "resolve_far", "resolve_far_factor", "refine",
                               "steady_average", "cold_start", "steady_window", "steady_window_change"})
        out = cls(
            solver=ctx.raw(table, "solver", default="swe"),
            resolution=ctx.quantity(table, "resolution", "length", default="1 m", positive=True),
            order=ctx.raw(table, "order", types=(int,), default=2),
            courant=ctx.quantity(table, "courant", "dimensionless", default=0.45, default_unit="", positive=True),
            tolerance=ctx.quantity(table, "tolerance", "1/s", default="2e-4 1/s", positive=True),
            t_max_initial=ctx.quantity(table, "t_max_initial", "time", default="300 s", positive=True),
            t_max=ctx.quantity(table, "t_max", "time", default="300 s", positive=True),
            monitor_radius=ctx.quantity(table, "monitor_radius", "length", default="20 m", positive=True),
            snapshots=[ctx.base_dir / p for p in ctx.raw(table, "snapshots", types=(list,), default=[])],
            threads=ctx.raw(table, "threads", types=(int,), default=1),
            resolve=ctx.raw(table, "resolve", default="full"),
            resolve_edge_level=ctx.quantity(table, "resolve_edge_level", "length", default="0.03 m", positive=True),
            resolve_far=ctx.raw(table, "resolve_far", default="frozen"),
            resolve_far_factor=ctx.raw(table, "resolve_far_factor", types=(int,), default=2),
            steady_average=ctx.raw(table, "steady_average", types=(bool,), default=False),
            cold_start=ctx.raw(table, "cold_start", default="cold"),
            steady_window_change=ctx.quantity(table, "steady_window_change", "dimensionless", default=WINDOW_CHANGE,
                                              default_unit="", positive=True),
        )
        if table.get("steady_window", "auto") != "auto":
            out.steady_window = ctx.quantity(table, "steady_window", "time", nonnegative=True)
        if not out.steady_window_change < 1:
            raise ctx.error(f"steady_window_change = {out.steady_window_change!r}: a relative range, needs < 1",
                            "steady_window_change")
        from ...hydro.coarse_start import COLD_STARTS

        if out.cold_start not in COLD_STARTS:
            raise ctx.error(f"cold_start = {out.cold_start!r}; use one of {list(COLD_STARTS)}", "cold_start")
        if out.threads < 1:
            raise ctx.error(f"threads = {out.threads}: needs at least 1", "threads")
        out.refine = ctx.quantity(table, "refine", "length", positive=True)
        out.resolve_margin = ctx.quantity(table, "resolve_margin", "length", positive=True)
        if "nested_box" in table:
            w = ctx.raw(table, "nested_box", types=(list,))
            if len(w) != 4:
                raise ctx.error("nested_box = [x0, x1, y0, y1] (lengths) of the nested local model", "nested_box")
            vals = [ctx.quantity({"nested_box": v}, "nested_box", "length") for v in w]
            if not (vals[1] > vals[0] and vals[3] > vals[2]):
                raise ctx.error(f"nested_box {w}: needs x0 < x1 and y0 < y1", "nested_box")
            out.nested_box = tuple(vals)
        if out.resolve not in RESOLVE_MODES:
            raise ctx.error(f"resolve = {out.resolve!r}; use one of {list(RESOLVE_MODES)}", "resolve")
        from ...hydro.far_field import far_fields

        if out.resolve_far not in far_fields:
            raise ctx.error(f"resolve_far = {out.resolve_far!r}; use one of {far_fields.available()}", "resolve_far")
        if out.resolve_far_factor < 2:
            raise ctx.error(f"resolve_far_factor = {out.resolve_far_factor}: needs at least 2", "resolve_far_factor")
        if out.refine is not None:
            if out.solver != "swe":
                raise ctx.error(f"refine (a nested fine grid around the breach) needs solver = 'swe', not {out.solver!r}",
                                "refine")
            if not out.refine < out.resolution:
                raise ctx.error(f"refine = {out.refine:g} m must be finer than resolution = {out.resolution:g} m", "refine")
        if out.solver in SNAPSHOT_SOLVERS and not out.snapshots:
            raise ctx.error(f"solver {out.solver!r} needs snapshots = [files]", "solver")
        if out.solver == "snapshot":
            import warnings

            warnings.warn(f"{ctx.path or '<scenario>'}: [hydro] solver = 'snapshot' is deprecated; it is 'snapshot_frozen' "
                          "(the ingested flow served unchanged, it does not respond to the pile)", DeprecationWarning,
                          stacklevel=2)
        return out
