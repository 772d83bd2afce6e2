"""Diagnosis workflow: find where a model and measured data disagree, name the missing
physical effect from the catalogue, add it, show the held-out gap shrink.

Modules: :mod:`.catalogue` (effects), :mod:`.plants` (what the workflow needs per plant),
:mod:`.records` (data checks, windows), :mod:`.models` (base models, thresholds),
:mod:`.fitting` (fits, held-out scores), :mod:`.residuals` (residual maps, signature ranking),
:mod:`.candidates` (candidate refits and judgement), :mod:`.floor` (noise floor of the held-out
residual, where a mismatch remains), :mod:`.workflow` (the loop and the verdict), :mod:`.synthetic`
(hidden-effect data), :mod:`.report` (markdown + figures), :mod:`.cli` (``hydro diagnose``).

Names are imported lazily (``hydro --help`` must not load numba and scipy through the
``diagnose`` sub-command's parser).
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "CATALOGUE": "catalogue", "Effect": "catalogue", "effect": "catalogue", "effects_for": "catalogue",
    "PLANTS": "plants", "diagnosis_plant": "plants",
    "DiagnosisError": "records", "DiagnosisDataError": "records", "DiagnosisFitError": "records", "Record": "records", "record_from_measured": "records",
    "DiagnosisResult": "workflow", "Model": "models", "diagnose": "workflow",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"identification.diagnosis.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'identification.diagnosis' has no attribute {name!r}")
