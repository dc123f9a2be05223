"""Reading and writing the project's files: measured/simulated data sets (DESIGN.md §3).

Linear model files (`.npz`) are read and written by :func:`freeplayid.model.load_system` and
:func:`freeplayid.model.save_system`.
"""

from .dataset import Dataset, DatasetError, Run, read_dataset, write_dataset
from .uff import read_uff, write_uff

__all__ = [
    "Dataset", "DatasetError", "Run", "read_dataset", "write_dataset", "read_uff", "write_uff",
]
