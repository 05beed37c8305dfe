"""The diagnosis: what the simulation gets wrong (a column, a form, a size), and the extension with it.

``diagnose`` ranks the candidate causes of the in-support approximate residual
(:mod:`.selection`: candidates, held-out fits, the naming rules, confounding and the table);
:mod:`.extension` adds the chosen causes to the surrogate and guards the result out of the support.
"""

import importlib

# names exported lazily (PEP 562): a report page that needs only the wording does not import scikit-learn
_EXPORTS = {
    "Candidate": "candidates",
    "build_candidates": "candidates",
    "Fit": "fits",
    "Rules": "fits",
    "best_fit": "fits",
    "Diagnosis": "selection",
    "diagnose": "selection",
    "Settings": "settings",
    "summary_dict": "table",
}


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)


__all__ = [
    "Candidate",
    "Diagnosis",
    "Fit",
    "Rules",
    "Settings",
    "best_fit",
    "build_candidates",
    "diagnose",
    "summary_dict",
]
