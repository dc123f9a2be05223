"""Reading and writing the project's files: measured/simulated data sets (DESIGN.md §3).

Identification results (``identification.json``): :func:`write_identification` and
:func:`read_identification`. Linear model files (`.npz`) are read and written by
:func:`freeplayid.model.load_system` and :func:`freeplayid.model.save_system`.
"""

from .dataset import Dataset, DatasetError, Run, read_dataset, write_dataset
from .result import ResultFileError, read_identification, write_identification
from .uff import read_uff, write_uff

__all__ = [
    "Dataset", "DatasetError", "Run", "read_dataset", "write_dataset", "read_uff", "write_uff",
    "read_identification", "write_identification", "ResultFileError",
]
