"""The diagnosis: what the simulation gets wrong (a column, a form, a size), and the extension with it.

``diagnose`` ranks the candidate causes of the in-support approximate residual
(:mod:`.selection`: candidates, held-out fits, the naming rules, confounding and the table);
:mod:`.extension` adds the chosen causes to the surrogate and guards the result out of the support.
"""

from hybridtwin.diagnosis.candidates import Candidate, build_candidates
from hybridtwin.diagnosis.fits import Fit, Rules, best_fit
from hybridtwin.diagnosis.selection import Diagnosis, diagnose
from hybridtwin.diagnosis.settings import Settings
from hybridtwin.diagnosis.table import summary_dict

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
