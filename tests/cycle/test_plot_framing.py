"""The plan view frames the scene it shows: the breach and every placed mass inside the axes, map
coordinates of a site written in full (no "+6.761e5" offset) with the CRS name, and every title inside
the figure without overlapping another (checked on the rendered figure with the renderer's boxes).

The cycle files are synthetic (a wide breach, masses far from its centre) so that the expected extent
is known by construction.
"""
import numpy as np
import pytest
import xarray as xr
from pyproj import CRS

from breachflow.cycle.plots import plan_view_figure


class FakeRun:
    """What the plots read of a run directory: its cycles, their files and the manifest."""

    def __init__(self, datasets, reason_len=1):
        self.ds = datasets
        crit = {"max_speed": {"value": 0.0766, "threshold": 0.5, "units": "m s-1", "satisfied": True}}
        crit.update({f"another_long_criterion_name_{k}": {"value": 1.0, "threshold": 2.0, "units": "m3 s-1",
                                                           "satisfied": True} for k in range(reason_len)})
        self._man = {"cycles": [{"cycle": g, "summary": {"closed": True, "criteria": crit, "breach_discharge": 12.5,
                                                          "seepage_discharge": 3.2, "governing": "max_speed"}}
                                for g in sorted(datasets)], "metadata": {}}

    def completed_cycles(self):
        return sorted(self.ds)

    def open_cycle(self, g):
        return self.ds[g]

    def manifest(self):
        return self._man


def cycle_ds(x0=0.0, y0=0.0, half_breach=30.5, masses=((-28.0, -30.0, 3.0), (29.0, 31.0, 4.0)), site=False, dx=2.0):
    x = x0 + np.arange(-70.0, 70.0 + dx / 2, dx)
    y = y0 + np.arange(-50.0, 50.0 + dx / 2, dx)
    shape = (y.size, x.size)
    rng = np.random.default_rng(0)
    ds = xr.Dataset({"u": (("y", "x"), rng.uniform(0, 2, shape)), "v": (("y", "x"), rng.uniform(-1, 1, shape)),
                     "wet": (("y", "x"), np.ones(shape, "i1")),
                     "bed_elevation": (("y", "x"), np.add.outer(0.01 * (y - y0), 0.02 * (x - x0)))},
                    coords={"x": x, "y": y})
    m = np.array(masses, float)
    ds["particle_x"] = ("particle", x0 + m[:, 0])
    ds["particle_y"] = ("particle", y0 + m[:, 1])
    ds["particle_diameter"] = ("particle", m[:, 2])
    ds["particle_active"] = ("particle", np.ones(len(m), "i1"))
    ds["particle_resting"] = ("particle", np.ones(len(m), "i1"))
    ds.attrs["breach_section"] = f"{x0 - half_breach} {x0 + half_breach} {y0}"
    if site:
        ds["crs"] = xr.DataArray(0, attrs={"crs_wkt": CRS.from_epsg(32615).to_wkt()})
        ds.attrs["site_breach_centre"] = f"{x0} {y0}"
    return ds


def _render(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _inside(inner, outer, tol=1.0):
    return (inner.x0 >= outer.x0 - tol and inner.x1 <= outer.x1 + tol and inner.y0 >= outer.y0 - tol
            and inner.y1 <= outer.y1 + tol)


def _check_frame(fig, datasets):
    for ax, ds in zip(fig.axes, datasets):
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        bx0, bx1, by = (float(v) for v in ds.attrs["breach_section"].split())
        assert x0 <= bx0 and x1 >= bx1 and y0 <= by <= y1, (ax.get_xlim(), ax.get_ylim())
        r = ds.particle_diameter.values / 2
        px, py = ds.particle_x.values, ds.particle_y.values
        assert x0 <= (px - r).min() and (px + r).max() <= x1, (ax.get_xlim(), px)
        assert y0 <= (py - r).min() and (py + r).max() <= y1, (ax.get_ylim(), py)
        # framed: not the whole domain when the scene is smaller (here the grid is 140 m x 100 m)
        assert x1 - x0 <= 140.0 + 2.0


@pytest.mark.parametrize("offset", [(0.0, 0.0), (5.0, -7.0)])
def test_plan_view_frames_the_breach_and_every_mass(offset):
    ds = {1: cycle_ds(*offset), 4: cycle_ds(*offset, masses=((-28.0, -30.0, 3.0), (29.0, 31.0, 4.0), (0.0, 0.0, 2.0)))}
    fig = plan_view_figure(FakeRun(ds))
    _check_frame(fig, [ds[1], ds[4]])


def test_site_plot_uses_plain_map_coordinates_and_titles_fit():
    e, n = 676100.0, 3372000.0
    ds = {1: cycle_ds(e, n, site=True), 2: cycle_ds(e, n, site=True)}
    fig = plan_view_figure(FakeRun(ds, reason_len=4))
    renderer = _render(fig)
    _check_frame(fig, [ds[1], ds[2]])
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"][:2]
    for ax in panels:
        for axis in (ax.xaxis, ax.yaxis):
            assert axis.get_offset_text().get_text() == "", axis.get_offset_text().get_text()
            labels = [t.get_text() for t in axis.get_ticklabels() if t.get_text()]
            assert labels and all("e" not in t and "+" not in t for t in labels), labels
        # full eastings / northings: the labels read back as numbers within the axis range
        vals = [float(t.get_text().replace(",", "").replace("\u2212", "-")) for t in ax.xaxis.get_ticklabels() if t.get_text()]
        assert min(vals) > 600000 and max(vals) < 700000
        assert "WGS 84 / UTM zone 15N" in ax.get_xlabel() and "WGS 84 / UTM zone 15N" in ax.get_ylabel()
    fig_box = fig.bbox
    titles = [fig._suptitle, *(ax.title for ax in panels)]
    boxes = [t.get_window_extent(renderer) for t in titles]
    for t, b in zip(titles, boxes):
        assert t.get_text() and _inside(b, fig_box), (t.get_text(), b, fig_box)
    # the panel titles overlap neither each other nor the other panel, nor the figure title
    a, b = boxes[1], boxes[2]
    assert not a.overlaps(b)
    assert not a.overlaps(panels[1].get_window_extent(renderer)) and not b.overlaps(panels[0].get_window_extent(renderer))
    assert not boxes[0].overlaps(a) and not boxes[0].overlaps(b)


def test_long_closure_reason_stays_inside_a_single_panel_figure():
    ds = {3: cycle_ds()}
    fig = plan_view_figure(FakeRun(ds, reason_len=6))
    renderer = _render(fig)
    assert _inside(fig._suptitle.get_window_extent(renderer), fig.bbox)
    _check_frame(fig, [ds[3]])
