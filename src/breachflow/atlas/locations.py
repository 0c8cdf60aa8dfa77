"""Candidate breach locations along a levee line and the local levee cross-section at each, read off the terrain.

At chainage ``s`` the terrain is sampled along the normal to the line, 5 profiles spaced 5 m along it
(the median profile is used, so that one ditch or lidar artefact does not decide the section):

* crest elevation ``z_c``: the highest point within ``crest_search`` (15 m) of the centreline;
* protected-side ground ``z_p`` and flood-side ground ``z_f``: the median ground between 1 and 3 levee
  heights beyond the toe, where the profile has come down from the crest (the toe: where the profile stops falling);
* levee height ``h_L = z_c - z_p``; crown width: where the profile stays within 10 cm of the crest;
  side slopes (H per V) from the crown edges to the toes.

The breach is taken down to the protected-side ground (the usual end state of an overflowing breach in a
levee on a low polder): the head that drives the breach flow is ``h_W = flood level - z_p``.
"""
from __future__ import annotations

import functools
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError
from ..site.geometry import LeveeLine
from ..site.terrain import Terrain

PROFILE_REACH = 150.0     #: how far the cross-section is sampled each side of the centreline (m)
PROFILE_STEP = 1.0
PROFILE_ALONG = (-10.0, -5.0, 0.0, 5.0, 10.0)
CREST_SEARCH = 15.0
CROWN_TOLERANCE = 0.10


@dataclass(frozen=True)
class Location:
    """A candidate breach: chainage (m), map position and direction, and the local levee section (SI)."""

    index: int
    chainage: float
    x: float
    y: float
    tangent: tuple[float, float]
    crest: float
    protected_ground: float
    flood_ground: float
    crown_width: float
    flood_slope: float
    protected_slope: float
    toe_protected: float   #: distance (m) from the centreline to the protected-side toe
    toe_flood: float
    user_point: bool = False

    @property
    def levee_height(self) -> float:
        return self.crest - self.protected_ground

    def as_dict(self) -> dict:
        return asdict(self)


def chainages(length: float, spacing: float, points=(), margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Chainages (m) at *spacing* from ``margin + spacing/2`` to ``length - margin``, merged with the user's
    *points*; returns ``(chainage, is_user_point)`` sorted by chainage."""
    if not spacing > 0:
        raise InputError(f"[district] spacing must be > 0 m, got {spacing}")
    usable = length - 2.0 * margin
    if usable <= 0:
        raise InputError(f"[district] margin {margin:g} m leaves nothing of the {length:.0f} m levee line")
    n = max(int(usable // spacing), 1)
    regular = margin + (np.arange(n) + 0.5) * (usable / n)
    pts = np.asarray(points, float)
    bad = pts[(pts < 0) | (pts > length)]
    if bad.size:
        raise InputError(f"[district] points: chainage {bad[0]:g} m is beyond the levee line (0 to {length:.1f} m)")
    s = np.concatenate([regular, pts])
    user = np.concatenate([np.zeros(regular.size, bool), np.ones(pts.size, bool)])
    order = np.argsort(s, kind="stable")
    return s[order], user[order]


def cross_section(levee: LeveeLine, terrain: Terrain, s: float, flood_side: str) -> dict:
    """The levee section at chainage *s* (see the module docstring); NaN fields where the terrain has none."""
    t = levee.tangent(s)
    n_left = np.array([-t[1], t[0]])
    offs = np.arange(-PROFILE_REACH, PROFILE_REACH + PROFILE_STEP / 2, PROFILE_STEP)
    profiles = []
    for a in PROFILE_ALONG:
        p = levee.point(min(max(s + a, 0.0), levee.length))
        pts = p[None, :] + offs[:, None] * n_left[None, :]
        profiles.append(terrain.sample(pts[:, 0], pts[:, 1]))
    z = np.nanmedian(np.array(profiles), axis=0) if np.isfinite(profiles).any() else np.full(offs.size, np.nan)
    mid = np.abs(offs) <= CREST_SEARCH
    if not np.isfinite(z[mid]).any():
        raise InputError(f"{terrain.path}: no terrain at the levee centreline at chainage {s:.0f} m")
    k = np.flatnonzero(mid)[np.nanargmax(z[mid])]
    crest = float(z[k])
    crown = np.abs(z - crest) <= CROWN_TOLERANCE
    lo = hi = k
    while lo > 0 and crown[lo - 1]:
        lo -= 1
    while hi < z.size - 1 and crown[hi + 1]:
        hi += 1
    crown_width = float(offs[hi] - offs[lo])
    left = _toe(offs, z, hi, +1, crest)
    right = _toe(offs, z, lo, -1, crest)
    flood, prot = (left, right) if flood_side == "left" else (right, left)
    flood_edge, prot_edge = (offs[hi], offs[lo]) if flood_side == "left" else (offs[lo], offs[hi])
    slope = lambda toe, edge: abs(toe["offset"] - edge) / max(crest - toe["ground"], 1e-3)  # noqa: E731
    return {"crest": crest, "protected_ground": prot["ground"], "flood_ground": flood["ground"],
            "crown_width": crown_width, "flood_slope": slope(flood, flood_edge),
            "protected_slope": slope(prot, prot_edge), "toe_protected": abs(prot["offset"]),
            "toe_flood": abs(flood["offset"])}


def _toe(offs, z, start: int, step: int, crest: float) -> dict:
    """Walk from the crown edge *start* in direction *step* until the profile stops falling (the toe: the
    first point whose next 10 m stay within 0.15 m of it); the ground there is the median of the next
    ``2 x levee height`` metres beyond the toe."""
    i = start
    n = z.size
    while 0 <= i + step < n and np.isfinite(z[i + step]):
        ahead = z[i + step: i + step * 11: step] if step > 0 else z[max(i + step * 10, 0): i + 1][::-1]
        ahead = ahead[np.isfinite(ahead)]
        if ahead.size and np.all(np.abs(ahead - z[i]) <= 0.15) and z[i] < crest - 0.5:
            break
        i += step
    height = max(crest - z[i], 0.5)
    j = int(np.clip(i + step * int(2 * height / PROFILE_STEP), 0, n - 1))
    seg = z[min(i, j): max(i, j) + 1]
    ground = float(np.nanmedian(seg)) if np.isfinite(seg).any() else float("nan")
    return {"offset": float(offs[i]), "ground": ground}


def locate(levee: LeveeLine, terrain: Terrain, *, spacing: float, points=(), margin: float = 0.0,
           flood_side: str = "left") -> list[Location]:
    """Every candidate location along *levee* with its section (see :func:`~breachflow.atlas.locations.chainages`, :func:`~breachflow.atlas.locations.cross_section`)."""
    s_all, user = chainages(levee.length, spacing, points, margin)
    out = []
    for i, (s, u) in enumerate(zip(s_all, user)):
        sec = cross_section(levee, terrain, float(s), flood_side)
        p = levee.point(float(s))
        t = levee.tangent(float(s))
        out.append(Location(index=i, chainage=float(s), x=float(p[0]), y=float(p[1]), tangent=(float(t[0]), float(t[1])),
                            user_point=bool(u), **sec))
    return out


@functools.lru_cache(maxsize=2)
def load_inputs(terrain_path: str, levee_path: str, crs, terrain_units):
    """Terrain and levee line, checked against each other, read once per process (a worker screens many
    locations on one terrain)."""
    from ..site.domain import _check_crosses, _check_crs
    from ..site.geometry import load_levee
    from ..site.terrain import load_terrain

    terrain = load_terrain(terrain_path, crs=crs, vertical_units=terrain_units)
    levee = load_levee(levee_path)
    _check_crs(terrain, levee)
    _check_crosses(terrain, levee)
    return terrain, levee
