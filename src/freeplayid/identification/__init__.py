"""The measured-data pipeline as one library function: :func:`identify` -> :class:`Identification`.

    from freeplayid import identify
    from freeplayid.io import read_dataset

    result = identify(read_dataset("examples/fin_sweeps"))
    print(result.kn, result.delta, result.kn_ci95)

Steps: the data set's linear model (or ``system``), the resonance (jump) point of every channel of
every usable run (ACMP or lock-in, the base channel subtracted when the data set has one, the
run's sweep hint when given), the start (the neural inverse model's estimate or the multi-start
grid), the backbone least squares with its intervals. No Hydra, no files: ``scripts/identify.py``
maps its config to these arguments and writes what the returned object holds.
"""


from .pipeline import identify
from .result import Identification, IdentificationError, SuspectResultError

__all__ = ["Identification", "IdentificationError", "SuspectResultError", "identify"]
