""":func:`check_records`: every record check on a data set, one :class:`RecordReport`."""

from __future__ import annotations

from ..dataset import Dataset
from ..model import FreeplaySystem
from .asymmetry import check_even_harmonics
from .cabling import check_cabling
from .context import Records
from .dropout import check_dropout
from .hum import check_hum
from .options import CHECK_NAMES, RecordCheckOptions
from .report import RecordReport
from .saturation import check_saturation
from .slow import check_offset
from .spike import check_spike
from .track import check_foreign_record, check_sample_rate, check_sweep_hint
from .units import check_units

__all__ = ["check_records", "CHECKS"]

# name -> check(records) -> list of Finding, in the order they run (a new check is one module
# and one line here and in options.CHECK_NAMES)
CHECKS = {
    "saturation": check_saturation,
    "dropout": check_dropout,
    "spike": check_spike,
    "offset": check_offset,
    "hum": check_hum,
    "sample_rate": check_sample_rate,
    "sweep_hint": check_sweep_hint,
    "foreign_record": check_foreign_record,
    "cabling": check_cabling,
    "units": check_units,
    "even_harmonics": check_even_harmonics,
}
assert tuple(CHECKS) == CHECK_NAMES


def check_records(dataset, system=None, *, options: RecordCheckOptions | None = None
                  ) -> RecordReport:
    """Check a data set's records before they are trusted (docs/record_checks.md).

    Parameters
    ----------
    dataset : Dataset
        As read by :func:`freeplayid.io.read_dataset` or built in memory; runs the reader
        rejected (``Run.reason``) or with non-finite samples are left out.
    system : FreeplaySystem, optional
        The linear model: the cabling check compares channel amplitude ratios with its mode
        shape, and the units check without a base channel needs its transmissibility.
    options : RecordCheckOptions, optional
        The checks to run and their thresholds (default: all, documented defaults).

    Returns
    -------
    RecordReport
        One finding per fault (check, run, channel, size, action, message), the data set with
        the repairs applied (DC offset and drift, hum, a few spikes), and the checks skipped.
    """
    if not isinstance(dataset, Dataset):
        raise TypeError(f"`dataset` must be a freeplayid.dataset.Dataset, got "
                        f"{type(dataset).__name__}")
    if system is not None and not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem or None, got {type(system).__name__}")
    options = RecordCheckOptions() if options is None else options
    if not isinstance(options, RecordCheckOptions):
        raise TypeError(f"`options` must be a RecordCheckOptions, got {type(options).__name__}")
    records = Records(dataset, system, options)
    findings = []
    for name in options.checks:
        findings += CHECKS[name](records)
    return RecordReport(tuple(findings), records.repaired_dataset(), dict(records.skipped),
                        options)
