"""Reading and writing the project's files: measured/simulated data sets (docs/identify.md).

- :mod:`~freeplayid.io.manifest`: a data set's ``manifest.yaml`` parsed and checked into a
  :class:`~freeplayid.io.manifest.Manifest`;
- :mod:`~freeplayid.io.dataset_files`: :func:`read_dataset` (the manifest, then every run file) and
  :func:`write_dataset`;
- :mod:`~freeplayid.io.readers`: the run-file reader of each suffix,
  :data:`freeplayid.io.readers.READERS` (CSV, gzipped CSV, UFF 58, MATLAB ``.mat``, NI
  ``.tdms``); adding a file type is one module there and one registry line;
- :mod:`~freeplayid.io.modal_tests`: modal-test files (:func:`read_modal_test`);
- :mod:`~freeplayid.io.result_file`: identification results (``identification.json``),
  :func:`write_identification` and :func:`read_result_record` (the record as a dict; its older
  name :func:`read_identification` stays; ``freeplayid.read_identification`` gives the
  :class:`freeplayid.Identification`).

Linear model files (`.npz`) are read and written by :func:`freeplayid.model.load_system` and
:func:`freeplayid.model.save_system`. Every file is written all or nothing through
:func:`freeplayid.atomic.atomic_path` (re-exported here with :func:`atomic_write_text` and
:func:`staged_folder`).
"""

from ..atomic import atomic_path, atomic_write_text, staged_folder
from ..errors import DatasetError
from .dataset_files import Dataset, Run, bundled_example, read_dataset, write_dataset
from .modal_tests import ModalTestError, read_modal_test
from .readers.uff import read_uff, write_uff
from .result_file import (
    ResultFileError,
    read_identification,
    read_result_record,
    write_identification,
)

__all__ = [
    "Dataset", "DatasetError", "Run", "bundled_example", "read_dataset", "write_dataset",
    "read_uff", "write_uff",
    "read_identification", "read_result_record", "write_identification", "ResultFileError",
    "atomic_path",
    "atomic_write_text", "staged_folder", "read_modal_test", "ModalTestError",
]
