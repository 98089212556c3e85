"""The rule language: pack models, the loader (extends/overrides/disable), expressions."""

from blockqc.rules.loader import available_packs, load_pack
from blockqc.rules.model import Pack, Rule, Threshold

__all__ = ["Pack", "Rule", "Threshold", "available_packs", "load_pack"]
