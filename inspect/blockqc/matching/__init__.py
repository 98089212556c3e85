"""Automatic matching of a corrected image against a reference orthoimage (§RA-3)."""

from blockqc.matching.grid import COLUMNS, homogenize
from blockqc.matching.matcher import match_candidates, match_images
from blockqc.matching.settings import MatchSettings

__all__ = ["COLUMNS", "MatchSettings", "homogenize", "match_candidates", "match_images"]
