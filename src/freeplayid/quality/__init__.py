"""Record checks before identification: faults found, sized, repaired where that needs no guess.

    from freeplayid.quality import check_records

    report = check_records(read_dataset(path), system)
    report.rejected_runs      # {run: reason}
    report.suspect_reasons    # reasons no answer from these records can be trusted
    report.dataset            # the records with the repairs applied

The checks (:data:`CHECKS`, in the order they run; docs/record_checks.md): ``saturation`` (flat
tops), ``dropout`` (held values), ``spike``, ``offset`` (DC offset and drift), ``hum`` (mains
lines), ``sample_rate`` / ``sweep_hint`` / ``foreign_record`` (each run's frequency track against
its hint and the other runs), ``cabling`` (channel amplitude ratios against the model's mode
shape), ``units`` (levels against ``level_g``) and ``even_harmonics`` (a second harmonic that
a centred gap does not make; after a replay, :func:`replayed_even_harmonics` judges it again
against the answer's). Each finding carries an action:
``reject_run``, ``suspect``, ``warning`` or ``repaired``.
"""

from .asymmetry import replayed_even_harmonics
from .check import CHECKS, check_records
from .options import CHECK_NAMES, RecordCheckOptions
from .report import ACTIONS, Finding, RecordReport

__all__ = ["check_records", "CHECKS", "CHECK_NAMES", "RecordCheckOptions", "RecordReport",
           "Finding", "ACTIONS", "replayed_even_harmonics"]
