"""Whether an RPC describes the image it is given for: the crop within its image domain, the
footprint on the Earth, within its ground domain and on the DEM.

An RPC of another image, or one with its offsets or scales swapped or mistyped, still gives the
image a footprint, and the run stopped at the DEM, blaming it ("the DEM does not cover lon
44.04..44.06, lat 5.34..5.37"). These problems name the RPC file, the image, where its footprint
falls against the RPC's own domains (offsets ± DOMAIN_REACH scales, as `blockqc inspect` checks
a delivery's RPCs) and the DEM, and the likely cause.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blockqc.errors import Problem
from blockqc.rfm.model import DOMAIN_REACH, RPCModel, boxes_meet, lon_turn
from blockqc.rfm.ortho import image_border

Box = tuple[float, float, float, float]
"""West, south, east, north in degrees."""

_GROUND = f"LONG_OFF ± {DOMAIN_REACH:g}·LONG_SCALE, LAT_OFF ± {DOMAIN_REACH:g}·LAT_SCALE"
_IMAGE = f"LINE_OFF ± {DOMAIN_REACH:g}·LINE_SCALE, SAMP_OFF ± {DOMAIN_REACH:g}·SAMP_SCALE"
_HEIGHT = f"HEIGHT_OFF ± {DOMAIN_REACH:g}·HEIGHT_SCALE"
#: what an RPC whose footprint is not where it says usually is (`blockqc inspect`'s words)
_ANOTHER = (
    "expected the RPC of this image (another image's file, offsets and scales swapped, or "
    "coefficients mistyped?)"
)


def _deg(value: float) -> str:
    """Degrees as the messages write them: 4 decimals, 4 digits for a value off the Earth."""
    return f"{value:.4f}" if abs(value) < 1e4 else f"{value:.4g}"


def box_text(box: Box) -> str:
    """'lon west..east, lat south..north'."""
    west, south, east, north = box
    return f"lon {_deg(west)}..{_deg(east)}, lat {_deg(south)}..{_deg(north)}"


def _span(start: float, end: float) -> str:
    return f"{start:.10g}..{end:.10g}"


def crop_problem(
    rpc: RPCModel,
    image: Path | str,
    shape: tuple[int, int],
    offset: tuple[float, float],
    option: str,
    given: bool,
) -> Problem | None:
    """A problem when the image's pixels (rows × cols at `offset` in the full image) reach
    beyond the RPC's image domain: the RPC of another, smaller image (the MS image's given for
    the PAN, another scene's) or a wrong crop offset; the RPC would be read far outside the
    part it was fitted to. `option` is the crop offset's option, `given` whether the user gave
    it (else it was read from the image's geotransform). An image within `_fitted_image` is
    held too."""
    line0, line1, samp0, samp1 = rpc.image_domain()
    rows, cols = shape
    last_row, last_col = offset[0] + rows - 1, offset[1] + cols - 1

    def holds(domain: tuple[float, float, float, float] | None) -> bool:
        if domain is None:
            return False
        first_line, last_line, first_sample, last_sample = domain
        within_lines = first_line <= offset[0] and last_row <= last_line
        return within_lines and first_sample <= offset[1] and last_col <= last_sample

    if holds((line0, line1, samp0, samp1)) or holds(_fitted_image(rpc)):
        return None
    source = f"given by {option}" if given else f"read from its geotransform ({option} auto)"
    return Problem(
        rpc.source,
        f"the RPC's image domain (lines {line0:.0f}..{line1:.0f}, samples {samp0:.0f}.."
        f"{samp1:.0f}: {_IMAGE}) does not hold the image {image} (rows "
        f"{_span(offset[0], last_row)}, columns {_span(offset[1], last_col)}: {rows} × {cols} px "
        f"at crop offset {offset[0]:.10g}, {offset[1]:.10g} {source}): expected the RPC of this "
        f"image (another image's file, e.g. the MS image's given for the PAN?) or another {option}",
    )


def _fitted_image(rpc: RPCModel) -> Box | None:
    """The image positions of the RPC's ground domain (first and last line and sample) when its
    LINE/SAMP offsets and scales are not those of the image its ground domain maps to: the
    ground domain's centre falls outside the image domain (s2p's crops: LINE_OFF 19403.5 ± 2·512,
    the centre at line 313). None when it falls inside, as for the RPCs of every vendor tried:
    their image domain is the image's (SkySat's ground domain of ±1° maps to a million lines)."""
    line0, line1, samp0, samp1 = rpc.image_domain()
    row, col = rpc.ground_to_image(rpc.lon_off, rpc.lat_off, rpc.height_off)
    if line0 <= row <= line1 and samp0 <= col <= samp1:
        return None
    return rpc.ground_domain_in_image()


def footprint_at(
    rpc: RPCModel, shape: tuple[int, int], offset: tuple[float, float], height: float
) -> Box | None:
    """The lon/lat box of the image's border taken to the ground at `height`; None when no
    border pixel has a ground position."""
    br, bc = image_border(*shape, per_edge=16)
    lon, lat, _ = rpc.image_to_ground(br + offset[0], bc + offset[1], height)
    ok = np.isfinite(lon) & np.isfinite(lat)
    if not ok.any():
        return None
    return (
        float(lon[ok].min()),
        float(lat[ok].min()),
        float(lon[ok].max()),
        float(lat[ok].max()),
    )


def _on_earth(box: Box) -> bool:
    """Latitudes within ±90°, longitudes within −180…360° (RPCs write either convention)."""
    west, south, east, north = box
    return -90.0 <= south and north <= 90.0 and -180.0 <= west and east <= 360.0


def _within(box: Box, other: Box) -> bool:
    """Whether the first lon/lat box lies inside the second (the first turned by `lon_turn`)."""
    west, south, east, north = box
    o_west, o_south, o_east, o_north = other
    turn = lon_turn(box, other)
    return o_west <= west + turn and east + turn <= o_east and o_south <= south and north <= o_north


def implausible_problem(
    rpc: RPCModel, image: Path | str, box: Box, height: float | None = None
) -> Problem | None:
    """A problem when the image's footprint by the RPC (`box`, at the DEM's mean `height`, or
    over the RPC's own height range when None) is off the Earth or reaches outside the RPC's own
    ground domain: the RPC does not describe this image (an image inside the RPC's image
    domain, at heights of its height domain, falls inside its ground domain). At a DEM height
    outside the RPC's height domain the likely cause is HEIGHT_OFF/HEIGHT_SCALE (a scale of
    1e-6 m sends a 560 m terrain to lon −2.6e5)."""
    domain = rpc.ground_domain()
    if _on_earth(box) and _within(box, domain):
        return None
    known = f"{box_text(domain)}: {_GROUND}"
    where = (
        f"off the Earth (the RPC's ground domain: {known})"
        if not _on_earth(box)
        else f"reaching outside the RPC's ground domain ({known})"
    )
    at = "" if height is None else f" at the DEM's mean height ({height:.0f} m)"
    low, high = rpc.height_domain()
    if height is not None and not low <= height <= high:
        reach = DOMAIN_REACH * abs(rpc.height_scale)
        cause = (
            f"that height lies outside the RPC's height domain ({rpc.height_off:g} ± {reach:g} "
            f"m: {_HEIGHT}): expected a HEIGHT_OFF and a HEIGHT_SCALE that span the image's "
            f"terrain (HEIGHT_SCALE {rpc.height_scale:g} m mistyped?)"
        )
    else:
        cause = _ANOTHER
    return Problem(
        rpc.source,
        f"the footprint of {image} by this RPC{at} lies at {box_text(box)}, {where}: {cause}",
    )


def _swapped_on(rpc: RPCModel, extent: Box) -> bool:
    """Whether the RPC's ground domain with latitudes and longitudes exchanged (LAT_OFF ±
    DOMAIN_REACH·LAT_SCALE taken as longitudes, LONG_OFF ± … as latitudes) meets the DEM."""
    west, south, east, north = rpc.ground_domain()
    swapped = (south, west, north, east)
    return _on_earth(swapped) and boxes_meet(swapped, extent)


def off_dem_problem(
    rpc: RPCModel, image: Path | str, box: Box, dem: Path | str, extent: Box | None
) -> Problem:
    """The problem of a footprint (`box`, over the RPC's height range) that the DEM (covering
    `extent`, None when unknown) does not reach, named on the RPC: the DEM is not at fault when
    the RPC is another image's, or has its latitude and longitude offsets swapped (LAT_OFF
    5.28, LONG_OFF 44.14 for Mont Ventoux: still a footprint on the Earth, inside the RPC's
    ground domain). Swapped offsets are named when, exchanged, they put the ground domain on
    the DEM."""
    covers = f"covers {box_text(extent)}" if extent is not None else "does not reach it"
    if extent is not None and _swapped_on(rpc, extent):
        cause = (
            f"LAT_OFF {rpc.lat_off:g} and LONG_OFF {rpc.lon_off:g} look swapped (exchanged, they "
            "put the RPC's ground domain on the DEM): expected the latitude offset in LAT_OFF, "
            "the longitude one in LONG_OFF"
        )
    else:
        cause = (
            "the RPC may belong to another image or have its latitude and longitude offsets "
            "swapped, or the DEM be of another area: expected the RPC of this image and a DEM "
            "under it"
        )
    return Problem(
        rpc.source,
        f"the footprint of {image} by this RPC lies at {box_text(box)} (the RPC's ground "
        f"domain: {box_text(rpc.ground_domain())}: {_GROUND}); the DEM {dem} {covers}: {cause}",
    )
