"""Reading and writing the project's files: measured/simulated data sets (docs/identify.md).

A data set's run files are read by the reader of their suffix, :data:`freeplayid.io.readers.READERS`
(CSV, gzipped CSV, UFF 58, MATLAB ``.mat``, NI ``.tdms``); adding a file type is one module there
and one registry line.

Identification results (``identification.json``): :func:`write_identification` and
:func:`read_identification`. Linear model files (`.npz`) are read and written by
:func:`freeplayid.model.load_system` and :func:`freeplayid.model.save_system`.
"""

from ..errors import DatasetError
from .atomic import atomic_write_text, staged_folder
from .dataset import Dataset, Run, read_dataset, write_dataset
from .modal import ModalTestError, read_modal_test
from .result import ResultFileError, read_identification, write_identification
from .uff import read_uff, write_uff

__all__ = [
    "Dataset", "DatasetError", "Run", "read_dataset", "write_dataset", "read_uff", "write_uff",
    "read_identification", "write_identification", "ResultFileError", "atomic_write_text",
    "staged_folder", "read_modal_test",
    "ModalTestError",
]
