"""A warm re-solve of the closure cycle is a steady state (issue 12, part 3).

The re-solve that ``breachflow run`` makes after the first cycle of the embedded default scenario
(its masses remapped into the flow) is compared with two references that do not depend on when the
steady-state test stops: the same warm start marched ten times longer, and a cold solve of the same
obstacles and bed from the scene's initial state. Its breach discharge must agree with both within
1 %, the mean and peak speed in the gap section with both within 0.5 %, and the domain's peak speed (in the
jet below the pile) with the marched-on warm start within 0.5 %. Before the breach discharge was part of the criterion (and with the
old defaults 2e-3 1/s, 60 s) the re-solve stopped after 33 s at +2.7 %.
"""
import numpy as np

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import CycleContext, MaxSpeed, gap_section_speeds, section_discharge
from breachflow.cycle.driver import ClosureRun
from breachflow.cycle.main import default_scenario_text
from breachflow.swe import SWESimulation
from breachflow.scenario.config import parse_scenario


class _Recorder:
    def __init__(self, solver):
        self.solver = solver
        self.calls = []

    def solve(self, domain, obstacles=None, initial=None):
        out = self.solver.solve(domain, obstacles=obstacles, initial=initial)
        if initial is not None:
            self.calls.append((domain, obstacles, initial, out, self.solver.warm.last))
        return out


def _measures(setup, ds):
    ctx = CycleContext(cycle=0, snapshot=ds, breach_x=setup.breach_x, levee_y=setup.levee_y)
    return section_discharge(ds, setup.breach_x, setup.levee_y), MaxSpeed("0 m/s").value(ctx)


def test_warm_resolve_of_the_default_scene_matches_a_long_resolve_and_a_cold_solve(tmp_path):
    text = default_scenario_text()
    assert "max_cycles = 24" in text and 'remap = "porous"' in text
    # the raised-bed remap: the masses change the bed the warm start must adjust to
    text = text.replace("max_cycles = 24", "max_cycles = 1").replace('remap = "porous"', 'remap = "raised_bed"')
    setup = closure_setup(parse_scenario(text))
    # record the solves as the flow model makes them: under the closure in time, inside the timeline's
    # wrapper, which moves the flood- and polder-side levels to the cycle's operation time
    outer = setup.solver if setup.timeline is not None else None
    rec = _Recorder(outer.inner if outer is not None else setup.solver)
    if outer is not None:
        outer.inner = rec
    else:
        setup.solver = rec
    ClosureRun(setup, tmp_path / "run", text).run()
    # the closure in time first solves the open breach at the flood stage and polder level of cycle 1's
    # operation time (bed unchanged), then re-solves with the cycle's masses: that re-solve is judged here
    assert len(rec.calls) == 1 + int(setup.timeline is not None)
    assert all(np.count_nonzero(c[0].bed != setup.domain.bed) == 0 for c in rec.calls[:-1])
    dom, obst, init, snap, sim = rec.calls[-1]
    assert np.count_nonzero(dom.bed != setup.domain.bed) > 0  # the masses raised the bed (remap)
    q, v = _measures(setup, snap)
    warm = rec.solver.warm

    long = SWESimulation(dom, warm.options, obstacles=obst, initial=init).advance_to(10.0 * sim.t)
    cold = SWESimulation(dom, warm.options, obstacles=obst)
    assert cold.run_to_steady(1e-4, 3000.0, region=warm.region).converged
    gap = gap_section_speeds(snap, setup.breach_x, setup.levee_y)
    for ref in (long, cold):
        ds_ref = ref.snapshot(derived=False)
        q_ref, v_ref = _measures(setup, ds_ref)
        assert abs(q / q_ref - 1.0) < 0.01, (q, q_ref, sim.t)
        # the speeds in the gap, where the criteria read them, within 0.5 % of both references
        for a, b in zip(gap, gap_section_speeds(ds_ref, setup.breach_x, setup.levee_y)):
            assert abs(a / b - 1.0) < 0.005, (gap, b, sim.t)
        if ref is long:
            # the domain's peak speed, in the supercritical jet below the pile, within 0.5 % of the same warm
            # start marched on; a cold start reaches a jet of another depth (0.675 m against 0.713 m at its peak
            # in the default scene: the jet below a dam is not unique), so its peak is not compared
            assert abs(v / v_ref - 1.0) < 0.005, (v, v_ref, sim.t)
    # the two references agree with each other far better: the steady state is unique
    q_long, _ = _measures(setup, long.snapshot(derived=False))
    q_cold, _ = _measures(setup, cold.snapshot(derived=False))
    assert abs(q_long / q_cold - 1.0) < 1e-3
    # the breach discharge is part of the steady-state criterion and recorded
    assert np.isfinite(sim.history.section_discharge).all()
    # (the solver monitors the levee-line row, SWESimulation.section_discharge; the closure reports the
    # median over the opening's rows, which a row through the pile exceeds — here by 10 %: issue 16)
    assert abs(sim.history.section_discharge[-1] - sim.section_discharge(warm.section)) < 1e-9 * abs(q)
