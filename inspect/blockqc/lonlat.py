"""Longitudes of a block on one side of ±180°: footprints unwrapped about the block's centre.

A block whose scenes straddle the antimeridian gives footprints from 179.8° to −179.8°, as the
contract wants them (longitudes within ±180°). Read as they are, a footprint spans the globe the
other way round: its area, its overlaps with its neighbours and the maps drawn of it are wrong.
Every figure over lon/lat footprints takes them unwrapped here instead, each vertex within 180°
of its footprint's first and each footprint turned by whole turns to lie nearest the block's
centre, so that such a block spans 179.8…180.2 (or −180.2…−179.8) as one piece. Footprints
that do not straddle ±180° come back exactly as given.
"""

from __future__ import annotations

import numpy as np
import shapely

from blockqc.rfm.model import lon_extent, wrap_lon


def turns_towards(lon: np.ndarray, centre: np.ndarray | float) -> np.ndarray:
    """The whole turns (multiples of 360°) that bring each `lon` within 180° of `centre`: zero,
    exactly, for a longitude already there."""
    return 360.0 * np.round((np.asarray(centre, float) - np.asarray(lon, float)) / 360.0)


def unwrap_about(lon: np.ndarray, centre: float) -> np.ndarray:
    """Longitudes brought within `centre` ± 180° (those already there kept exactly)."""
    lon = np.asarray(lon, float)
    return lon + turns_towards(lon, centre)


def centre_lon(lon: np.ndarray) -> float:
    """The middle of the shortest arc of longitude holding every `lon` (`lon_extent`), within
    ±180°; NaN without any."""
    west, east = lon_extent(np.asarray(lon, float)[np.isfinite(lon)])
    return float(wrap_lon((west + east) / 2.0))


def unwrapped(geoms: np.ndarray, centre: float | None = None) -> np.ndarray:
    """Lon/lat geometries (None where missing, kept) with their longitudes unwrapped: within
    each, about its first vertex; then each turned as a whole nearest `centre` (None: the
    centre of them all)."""
    geoms = np.array(geoms, dtype=object)
    flat = geoms.ravel()
    present = ~shapely.is_missing(flat) & ~shapely.is_empty(flat)
    if not present.any():
        return geoms
    parts = flat[present]
    xy, owner = shapely.get_coordinates(parts, return_index=True)
    first = np.searchsorted(owner, np.arange(len(parts)))  # every present geometry has vertices
    lon = xy[:, 0] + turns_towards(xy[:, 0], xy[first, 0][owner])
    west = np.full(len(parts), np.inf)
    east = np.full(len(parts), -np.inf)
    np.minimum.at(west, owner, lon)
    np.maximum.at(east, owner, lon)
    middle = (west + east) / 2.0
    lon += turns_towards(middle, centre_lon(middle) if centre is None else centre)[owner]
    if np.array_equal(lon, xy[:, 0]):
        return geoms
    xy[:, 0] = lon
    flat = flat.copy()
    flat[present] = shapely.set_coordinates(parts.copy(), xy)
    return flat.reshape(geoms.shape)
