"""Coordinate reference systems of what breachflow writes: one way in (pyproj), one way out (WKT GDAL reads).

:func:`resolve_crs` turns a CRS given as ``EPSG:nnnn``, WKT (1 or 2, ESRI ``.prj`` text), a PROJ string
or a ``.prj`` path into WKT via pyproj, refuses what pyproj cannot read, and refuses a CRS whose axis
unit disagrees with the unit of the coordinates it is attached to (a geographic CRS on metres, a US-foot
state plane on a mesh in metres). Coordinates are SI inside breachflow: a CRS in feet given for data in
feet is re-expressed with metre axes (same projection and false origin), so the metres written land
where the feet were.

:data:`LOCAL_CRS` is the default of closure runs, whose site coordinates are local (the breach centre
at x = y = 0, x along the levee): a transverse Mercator on WGS 84 centred on the 17th Street Canal
breach in New Orleans (30.0168 N, 90.1213 W; docs/theory.md, *Closure window* Katrina case), scale 1, false origin 0, 0, so
x/y are metres east/north of that point and a GIS shows the run there, at its true size.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError

#: Default CRS of closure runs: local transverse Mercator, origin at the 17th Street Canal breach.
LOCAL_CRS = ("+proj=tmerc +lat_0=30.0168 +lon_0=-90.1213 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m "
             "+no_defs +type=crs")
LOCAL_CRS_NAME = "breachflow local transverse Mercator (origin 30.0168 N, 90.1213 W: 17th Street Canal breach)"


def _pyproj_crs(crs, where: str):
    from pyproj import CRS

    text = str(crs).strip()
    if text and "[" not in text and not text.startswith("+") and Path(text).suffix.lower() == ".prj":
        try:
            text = Path(text).read_text(encoding="utf-8", errors="replace").strip()
        except OSError as exc:
            raise InputError(f"{where}: cannot read projection file {crs!r} ({exc.strerror})") from None
    try:
        return CRS.from_user_input(text)
    except Exception as exc:  # pyproj.exceptions.CRSError and friends
        raise InputError(f"{where}: cannot interpret the CRS {str(crs)[:80]!r} ({exc})") from None


def crs_length_unit(crs) -> tuple[str, float] | None:
    """(name, metres per unit) of the horizontal axes of a projected or engineering CRS; None when
    the axes are angular (geographic CRS) or unknown."""
    c = crs.sub_crs_list[0] if crs.is_compound else crs
    axes = [a for a in c.axis_info if a.direction.lower() in ("east", "north", "west", "south")] or c.axis_info[:2]
    if not axes or c.is_geographic or any(u in a.unit_name.lower() for a in axes[:2]
                                          for u in ("degree", "radian", "grad", "arc")):
        return None
    return axes[0].unit_name, float(axes[0].unit_conversion_factor)


def resolve_crs(crs, *, where: str = "crs", data_unit: str | None = "m", name: str | None = None,
                metres: bool = True) -> str:
    """WKT (WKT2 2019, what GDAL and pyproj read) of *crs*, checked against *data_unit*, the length
    unit of the coordinates it describes as they were given (``"m"``, ``"ft"``, ``"survey_foot"``;
    None: no check). A projected CRS in other units than metres is returned with metre axes (the
    coordinates are stored in metres; ``metres=False`` keeps its units). Errors (:class:`~breachflow.errors.InputError`)
    name *where*."""
    from pyproj.crs import ProjectedCRS
    from pyproj.crs.coordinate_system import Cartesian2DCS

    from ..units import ureg

    c = _pyproj_crs(crs, where)
    if name and c.name in ("unknown", "unnamed", ""):
        c = ProjectedCRS(conversion=c.coordinate_operation, geodetic_crs=c.geodetic_crs, name=name) \
            if c.is_projected else c
    unit = crs_length_unit(c)
    if data_unit is not None:
        if unit is None:
            raise InputError(f"{where}: the CRS {c.name!r} has angular or unknown axes "
                             f"({', '.join(a.unit_name for a in c.axis_info)}); the coordinates are lengths in "
                             f"{data_unit}: give a projected CRS")
        per_m = float(ureg.Quantity(1.0, data_unit).to("m").magnitude)
        if abs(unit[1] - per_m) > 1e-9 * per_m:
            raise InputError(f"{where}: the CRS {c.name!r} is in {unit[0]} ({unit[1]:.10g} m) but the coordinates "
                             f"are in {data_unit} ({per_m:.10g} m): give the CRS of the data's units or the "
                             f"data's units (--units; US survey feet: survey_foot)")
    if metres and unit is not None and abs(unit[1] - 1.0) > 1e-12:
        if not c.is_projected:
            raise InputError(f"{where}: the CRS {c.name!r} is in {unit[0]}; breachflow stores metres and can "
                             "re-express only a projected CRS in metres")
        c = ProjectedCRS(conversion=c.coordinate_operation, geodetic_crs=c.geodetic_crs,
                         cartesian_cs=Cartesian2DCS(), name=f"{c.name} (metre axes)")
    return c.to_wkt()


def local_crs_wkt() -> str:
    """WKT of :data:`LOCAL_CRS` (named)."""
    return resolve_crs(LOCAL_CRS, where="[site] crs", name=LOCAL_CRS_NAME)
