"""The measured-data pipeline as one library function: :func:`identify` -> :class:`Identification`.

    from freeplayid import identify
    from freeplayid.io import read_dataset

    result = identify(read_dataset("examples/fin_sweeps"))
    print(result.kn, result.delta, result.kn_ci95)

Steps (``pipeline``): the data set's linear model (or ``system``); the record checks
(:mod:`freeplayid.quality`, taken in by ``records``: repaired records, rejected runs, the
``records`` verdict check; ``records=None`` turns them off); the plain estimate
(:mod:`freeplayid.estimate`: the resonance point of every channel of every usable run, the fit's
start, the backbone least squares with its intervals); the corrected fit
(:mod:`freeplayid.replay`); the checks behind the verdict (``verdict``); one
:class:`Identification` (``result``) with its JSON record, its report (``report``) and its
figures (``figures``); :func:`read_identification` (``saved``) reads it back from its file.
No Hydra, no files: ``scripts/identify.py`` maps its config to these arguments and writes what
the returned object holds.
"""

from .pipeline import identify
from .result import Identification, IdentificationError, SuspectResultError
from .saved import read_identification
from .verdict import Check, Verdict

__all__ = ["Check", "Identification", "IdentificationError", "SuspectResultError", "Verdict",
           "identify", "read_identification"]
