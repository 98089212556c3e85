"""Quality evaluation and acceptance (§QE, GB/T 24356-2023): sampling, scores, grades, decision.

The mechanics are pack data (a pack's `acceptance:` section, `model.py`); the functions here are
pure: `sampling` picks the sample of a batch, `scoring` gives a block its score and grade from its
results, `decision` judges the sample and grades the batch.
"""

from blockqc.acceptance.model import Acceptance, ErrorClass, ScoreDef

__all__ = ["Acceptance", "ErrorClass", "ScoreDef"]
