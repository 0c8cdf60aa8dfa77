"""A monitoring region the flood has not reached yet is not a steady state: the solve goes on until the water
arrives (the atlas's members whose first solve stopped "steady" after 9 s with a dry breach)."""
import numpy as np

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid


def test_dry_monitoring_region_waits_for_the_flood():
    dom = uniform_grid(0, 4, 0, 200, 2.0, manning=0.03,
                       boundaries={"south": BC("level", level=2.0), "north": BC("outflow")})
    yy = dom.y[:, None] * np.ones(dom.shape)
    dom.initial_surface = np.where(yy < 20.0, 2.0, -1.0)  # water at the source end only, the rest dry
    region = yy > 180.0
    sim = SWESimulation(dom, SWEOptions(order=1))
    hist = sim.run_to_steady(1e-4, t_max=1200.0, region=region)
    # the front runs 160 m at a few m/s: the region is wet before the solve may call anything steady
    assert float(sim.depth[region].min()) > 0.1
    assert hist.time[-1] > 30.0
    if hist.converged:  # and a converged state has settled over the whole domain, not only the region
        assert hist.depth_rate[-1] < 1e-4
