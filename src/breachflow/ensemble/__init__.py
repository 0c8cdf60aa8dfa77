"""Scenario ensembles on dask: vary scenario parameters, run one member runner per combination, get one
labelled xarray Dataset (issue 8).

Notebook use::

    import breachflow.ensemble as ens
    ds = ens.run("feasibility.toml")                      # local cluster, one worker process per core
    ds = ens.run("feasibility.toml", scheduler="tcp://10.0.0.5:8786")   # any dask cluster
    ds.closure_window.sel(polder_area=8e6).plot()

Public API: :func:`run`, :func:`plan`, :func:`load_spec`, :func:`parse_spec`, :class:`EnsembleSpec`,
``member_runners`` (registry ``breachflow.member_runners``; built-ins ``closure_window``, ``closure`` and ``synthetic``),
:class:`MemberRunner` (protocol a runner implements), :class:`MemberScenario`, :func:`window_scalars`,
:func:`member_seed`, :func:`validate_result`, :func:`write_result`, :func:`open_result`.
"""
from .dataset import STATUS_FAILED, STATUS_NOT_RUN, STATUS_OK, build_dataset, open_result, validate_result, write_result
from .execute import execute_member, plan, run
from .runners import (CLOSURE_OUTPUTS, MemberRunner, MemberScenario, ResultValue, SyntheticRunner,
                      ClosureWindowRunner, member_runners, window_scalars)
from .spec import EnsembleSpec, Member, Parameter, as_spec, load_spec, member_seed, parse_spec

__all__ = [
    "run", "plan", "load_spec", "parse_spec", "as_spec", "EnsembleSpec", "Member", "Parameter", "member_seed",
    "member_runners", "MemberRunner", "MemberScenario", "ResultValue", "ClosureWindowRunner", "SyntheticRunner",
    "window_scalars", "CLOSURE_OUTPUTS", "execute_member", "build_dataset", "validate_result", "write_result", "open_result",
    "STATUS_OK", "STATUS_FAILED", "STATUS_NOT_RUN",
]
