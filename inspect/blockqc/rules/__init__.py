"""The rule language: pack models, the loader (extends/overrides/disable), expressions, lint,
and the pass/fail cases that ship beside each pack."""

from blockqc.rules.loader import available_packs, load_pack
from blockqc.rules.model import Pack, Rule, Threshold

__all__ = ["Pack", "Rule", "Threshold", "available_packs", "load_pack"]
