"""Settings of the §RA-3 matcher, with their defaults and the checks that keep them coherent."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields

from blockqc.errors import InputError, Problem


@dataclass(frozen=True)
class MatchSettings:
    """Parameters of the §RA-3 matcher; every field can be passed to `match_images` by name.

    Distances are in pixels of the (common) image/reference grid.
    """

    search_radius: int = 8
    """Half-size of the search window around the expected reference position (§RA-3)."""
    template: int = 21
    """Side of the square NCC template, odd."""
    harris_block: int = 5
    """Neighbourhood of the Harris structure tensor (cv2.cornerHarris blockSize)."""
    harris_ksize: int = 3
    """Sobel aperture of the Harris gradients."""
    harris_k: float = 0.04
    """Harris detector free parameter k."""
    harris_quality: float = 0.01
    """A corner's response must exceed this share of the chunk's 99.9th response percentile."""
    harris_min_distance: int = 5
    """Radius of the non-maximum suppression between corners."""
    corners_per_cell: int = 24
    """Strongest corners kept per grid cell (keeps the corners spread over the chunk)."""
    brief_patch: int = 48
    """Side of the BRIEF patch; the 512 point pairs are drawn inside it."""
    brief_sigma: float = 2.0
    """Gaussian smoothing before the BRIEF intensity tests (Calonder et al. 2010: 9x9, sigma 2)."""
    brief_seed: int = 512
    """Seed of the fixed BRIEF sampling pattern; image and reference use the same pattern."""
    max_hamming: int = 128
    """Largest Hamming distance (of 512 bits) of an accepted BRIEF match."""
    hamming_ratio: float = 0.9
    """Best Hamming distance must be below this share of the second best within the window."""
    refine_radius: int = 2
    """Radius of the NCC window that refines a BRIEF match to sub-pixel precision."""
    min_ncc: float = 0.7
    """Smallest NCC peak of an accepted NCC match (and of a BRIEF match's refinement)."""
    ncc_sigma: float = 1.0
    """Gaussian smoothing (px) of both chunks before NCC; it damps aliasing and noise so the
    correlation peak is closer to the quadratic the sub-pixel fit assumes (0 = none)."""
    ransac_model: str = "affine"
    """Model fitted by RANSAC per chunk: 'affine' or 'translation'."""
    ransac_threshold: float = 1.5
    """Largest residual (px) of a RANSAC inlier."""
    ransac_iterations: int = 500
    """Hypotheses drawn by RANSAC per chunk."""
    ransac_seed: int = 0
    """Seed of the RANSAC sampling, so runs repeat exactly."""

    @property
    def template_half(self) -> int:
        return self.template // 2

    @property
    def brief_half(self) -> int:
        return self.brief_patch // 2

    @property
    def margin(self) -> int:
        """Pixels a corner needs around it for both its template and its BRIEF patch."""
        return max(self.template_half, self.brief_half) + 1


def _problem(message: str) -> InputError:
    return InputError(Problem(file="<arguments>", message=message))


def _typed(overrides: dict[str, object]) -> tuple[dict[str, object], list[str]]:
    """The overrides as the type of their field's default (an integer, a finite number, a
    text), and a message for each that is not one."""
    defaults = {f.name: f.default for f in fields(MatchSettings)}
    typed: dict[str, object] = {}
    errors: list[str] = []
    for name, value in overrides.items():
        default = defaults[name]
        if isinstance(default, str):
            ok, kind = isinstance(value, str), "a text"
        elif isinstance(value, bool) or not isinstance(value, numbers.Real):
            ok, kind = False, "an integer" if isinstance(default, int) else "a finite number"
        elif isinstance(default, int):
            ok, kind = isinstance(value, numbers.Integral), "an integer"
        else:
            ok, kind = math.isfinite(value), "a finite number"
        if ok:
            typed[name] = type(default)(value)  # numpy scalars as Python numbers
        else:
            errors.append(f"{name} must be {kind}, got {value!r}")
    return typed, errors


def make_settings(**overrides: object) -> MatchSettings:
    """Build settings from keyword arguments, refusing unknown names and incoherent values."""
    names = {f.name for f in fields(MatchSettings)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise _problem(f"unknown matcher setting(s) {unknown}; known: {sorted(names)}")
    typed, errors = _typed(overrides)
    if errors:
        raise InputError([Problem(file="<arguments>", message=m) for m in errors])
    s = MatchSettings(**typed)  # type: ignore[arg-type]
    errors = _incoherent(s)
    if errors:
        raise InputError([Problem(file="<arguments>", message=m) for m in errors])
    return s


def _incoherent(s: MatchSettings) -> list[str]:
    """What is wrong with each value of `s` that its type alone does not rule out."""
    errors: list[str] = []
    positive_ints = (
        "search_radius",
        "template",
        "harris_block",
        "harris_min_distance",
        "corners_per_cell",
        "brief_patch",
        "refine_radius",
        "ransac_iterations",
    )
    for name in positive_ints:
        value = getattr(s, name)
        if value < 1:
            errors.append(f"{name} must be a positive integer, got {value!r}")
    if s.template % 2 == 0:
        errors.append(f"template must be odd, got {s.template}")
    if s.template < 5:
        errors.append(f"template must be at least 5 px, got {s.template}")
    if s.harris_ksize not in (1, 3, 5, 7):
        errors.append(f"harris_ksize must be 1, 3, 5 or 7, got {s.harris_ksize!r}")
    if not 0 < s.harris_quality < 1:
        errors.append(f"harris_quality must be in (0, 1), got {s.harris_quality!r}")
    if not 0 <= s.max_hamming <= 512:
        errors.append(f"max_hamming must be in [0, 512], got {s.max_hamming!r}")
    if not 0 < s.hamming_ratio <= 1:
        errors.append(f"hamming_ratio must be in (0, 1], got {s.hamming_ratio!r}")
    if not -1 <= s.min_ncc <= 1:
        errors.append(f"min_ncc must be in [-1, 1], got {s.min_ncc!r}")
    if s.ncc_sigma < 0:
        errors.append(f"ncc_sigma must be zero or positive, got {s.ncc_sigma!r}")
    if s.brief_sigma <= 0:
        errors.append(f"brief_sigma must be positive, got {s.brief_sigma!r}")
    if s.ransac_model not in ("affine", "translation"):
        errors.append(f"ransac_model must be 'affine' or 'translation', got {s.ransac_model!r}")
    for name in ("brief_seed", "ransac_seed"):
        if getattr(s, name) < 0:
            errors.append(f"{name} must be zero or a positive integer, got {getattr(s, name)!r}")
    if s.ransac_threshold <= 0:
        errors.append(f"ransac_threshold must be positive, got {s.ransac_threshold!r}")
    return errors
