"""The record checks (:mod:`freeplayid.quality`) taken into the identification.

:func:`checked_dataset` runs :func:`freeplayid.quality.check_records` before any extraction and
gives the data set to identify from: the repaired records, each run the checks reject marked
with their reason (``Run.reason``, as the reader marks a broken run), so the extraction leaves
it out and names that reason among the rejected runs, the verdict's data checks
(``base_level``) pass over it and the replay does not simulate it. A run rejected here does
not by itself make the verdict ``suspect``; :func:`record_checks` makes each of the report's
``suspect`` findings a failed verdict check ``records`` (a fault no fit can see: a wrong sample
rate, swapped channels, wrong units...). docs/record_checks.md says what each check catches.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from ..errors import ConfigError, IdentificationError
from ..quality import RecordCheckOptions, RecordReport, check_records
from .verdict import Check

__all__ = ["checked_dataset", "record_checks", "record_options", "REJECTED_BY_CHECKS"]

# the prefix of the reason of a run the record checks rejected (Run.reason, rejected_runs)
REJECTED_BY_CHECKS = "record checks: "


def record_options(value, fit_mode: int) -> RecordCheckOptions | None:
    """``identify``'s ``records`` argument as a :class:`RecordCheckOptions` (None: the checks
    off; a mapping: its fields), checking the resonance of the fitted backbone mode
    (``fit_mode``) unless another mode is set."""
    if value is None:
        return None
    if isinstance(value, Mapping):
        names = {f.name for f in dataclasses.fields(RecordCheckOptions)}
        unknown = sorted(set(value) - names)
        if unknown:
            raise TypeError(f"`records` has unknown field(s) {unknown}; valid: {sorted(names)}")
        value = RecordCheckOptions(**value)
    if not isinstance(value, RecordCheckOptions):
        raise TypeError(f"`records` must be a freeplayid.quality.RecordCheckOptions, a mapping "
                        f"of its fields or None (the checks off), got {type(value).__name__}")
    if value.mode == 0 and fit_mode != 0:  # the default: the fitted mode's resonance
        value = dataclasses.replace(value, mode=fit_mode)
    if value.mode != fit_mode:
        raise ConfigError(f"`records.mode` ({value.mode}) must be the fitted mode "
                         f"(`fit.mode` = {fit_mode}): the checks look at its resonance")
    return value


def checked_dataset(dataset, system, options: RecordCheckOptions | None
                    ) -> tuple[object, RecordReport | None]:
    """The data set to identify from, and the record checks' report (None when off).

    Raises
    ------
    IdentificationError
        Every run rejected (by the reader or by the checks), naming each run's reason: nothing
        is left to identify from, and no extraction is started.
    """
    if options is None:
        return dataset, None
    report = check_records(dataset, system, options=options)
    rejected = report.rejected_runs
    runs = tuple(dataclasses.replace(r, reason=REJECTED_BY_CHECKS + rejected[r.file])
                 if r.file in rejected and not r.reason else r for r in report.dataset.runs)
    if runs and all(r.reason for r in runs) and rejected:
        where = dataset.path or dataset.name or "data set"
        why = "; ".join(f"{r.file}: {r.reason}" for r in runs)
        raise IdentificationError(f"{where}: every run is rejected, nothing is left to identify "
                                  f"from ({why}); see docs/record_checks.md")
    return dataclasses.replace(report.dataset, runs=runs), report


def record_checks(report: RecordReport | None) -> list[Check]:
    """The record checks as verdict checks ``records``: one failed check per ``suspect``
    finding (its message names the fault, the run and the channel), else one passed check
    saying what was found and done (none when the checks were off)."""
    if report is None:
        return []
    suspects = [f for f in report.findings if f.action == "suspect"]
    if suspects:
        return [Check("records", False, f"record check `{f.check}`: {f.message}", f.size)
                for f in suspects]
    return [Check("records", True, "record checks: " + findings_text(report))]


def findings_text(report: RecordReport) -> str:
    """What the checks found and did, in a few words ("nothing found", "1 run rejected
    (a.csv), 2 repairs, 1 warning (hum)"), with the checks that could not run."""
    rejected = report.rejected_runs
    parts = []
    if rejected:
        parts.append(f"{len(rejected)} run{'s' if len(rejected) > 1 else ''} rejected "
                     f"({', '.join(rejected)})")
    for action, one, many in (("suspect", "suspect finding", "suspect findings"),
                              ("repaired", "repair", "repairs"),
                              ("warning", "warning", "warnings")):
        n = sum(f.action == action for f in report.findings)
        if n:
            parts.append(f"{n} {one if n == 1 else many}")
            if action == "warning":  # which checks warned: the verdict's line names them
                parts[-1] += " (" + ", ".join(dict.fromkeys(
                    f.check for f in report.findings if f.action == action)) + ")"
    text = ", ".join(parts) or "nothing found"
    if report.skipped:
        text += f" (not checked: {', '.join(report.skipped)})"
    return text
