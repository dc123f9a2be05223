"""What the record checks found: one :class:`Finding` per fault, in a :class:`RecordReport`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["ACTIONS", "Finding", "RecordReport"]

# what a finding does to the identification, most severe first:
# - reject_run: the run's points cannot be trusted (a cut or missing resonance, another test's
#   record); the identification goes on without the run, naming this reason;
# - suspect: the answer cannot be trusted whatever the fit says (a wrong sample rate, swapped
#   channels, units): the verdict becomes `suspect` with this reason;
# - warning: dirty but usable (the fault leaves the fitting points alone); reported only;
# - repaired: removed without guessing (DC offset and drift, mains hum, a few spikes); the
#   report's data set holds the repaired records.
ACTIONS = ("reject_run", "suspect", "warning", "repaired")


@dataclass(frozen=True)
class Finding:
    """One fault found in the records.

    Attributes
    ----------
    check : str
        The check that found it (:data:`freeplayid.quality.CHECK_NAMES`).
    run : str
        The run's file, or "" for a fault of the whole data set.
    channel : str
        The column (a response channel or the base channel), or "" for the whole run.
    size : float
        The fault's size in ``unit`` (NaN where it has none).
    unit : str
        Unit of ``size`` ("% of peak", "s", "g", "Hz", "x", ...).
    action : str
        One of :data:`ACTIONS`.
    message : str
        One sentence naming the run, the channel, the fault and its size.
    """

    check: str
    run: str
    channel: str
    size: float
    unit: str
    action: str
    message: str

    def __post_init__(self) -> None:
        if self.action not in ACTIONS:
            raise ValueError(f"`action` must be one of {ACTIONS}, got {self.action!r}")

    def size_text(self) -> str:
        """The size with its unit ("80.1 % of peak", "0.5 s"), or "-"."""
        if not math.isfinite(self.size):
            return "-"
        return f"{self.size:.3g} {self.unit}".strip()

    def to_dict(self) -> dict:
        return {"check": self.check, "run": self.run, "channel": self.channel,
                "size": float(self.size) if math.isfinite(self.size) else None,
                "unit": self.unit, "action": self.action, "message": self.message}


@dataclass(frozen=True)
class RecordReport:
    """Result of :func:`freeplayid.quality.check_records`.

    Attributes
    ----------
    findings : tuple of Finding
        Every fault found, in the order of the checks, then of the runs.
    dataset : Dataset
        The data set to identify from: the input with the repairs applied (the input itself
        when nothing was repaired). Rejected runs are still in it; ``rejected_runs`` names them.
    skipped : dict of str -> str
        Checks (or parts of them) that could not run, and why (no model, no hint, ...).
    options : RecordCheckOptions or None
        The checks' options (what a later look at a finding judges it by; None: the defaults).
    """

    findings: tuple = ()
    dataset: object = None
    skipped: dict = field(default_factory=dict)
    options: object = None

    def _messages(self, action: str) -> tuple[str, ...]:
        return tuple(f.message for f in self.findings if f.action == action)

    @property
    def rejected_runs(self) -> dict:
        """Run file -> the reasons (joined by "; ") of the findings that reject it."""
        out: dict = {}
        for f in self.findings:
            if f.action == "reject_run":
                out[f.run] = f"{out[f.run]}; {f.message}" if f.run in out else f.message
        return out

    @property
    def suspect_reasons(self) -> tuple[str, ...]:
        """Reasons that make any answer from these records ``suspect``."""
        return self._messages("suspect")

    @property
    def warnings(self) -> tuple[str, ...]:
        """Dirty but usable records."""
        return self._messages("warning")

    @property
    def repairs(self) -> tuple[str, ...]:
        """What was repaired in ``dataset``."""
        return self._messages("repaired")

    @property
    def clean(self) -> bool:
        """True when nothing was found."""
        return not self.findings

    def by_check(self, check: str) -> tuple[Finding, ...]:
        """The findings of one check."""
        return tuple(f for f in self.findings if f.check == check)

    def to_records(self) -> list[dict]:
        """JSON-ready findings."""
        return [f.to_dict() for f in self.findings]

    def to_markdown(self) -> str:
        """A Markdown table of the findings (and the skipped checks)."""
        if not self.findings:
            lines = ["Record checks: nothing found."]
        else:
            lines = ["| check | run | channel | size | action | message |",
                     "|---|---|---|---|---|---|"]
            lines += [f"| {f.check} | {f.run or 'all'} | {f.channel or 'all'} | "
                      f"{f.size_text()} | {f.action} | {f.message} |" for f in self.findings]
        if self.skipped:
            lines += ["", *(f"- {name} not checked: {why}" for name, why in self.skipped.items())]
        return "\n".join(lines)

    def __repr__(self) -> str:
        counts = {a: sum(f.action == a for f in self.findings) for a in ACTIONS}
        found = ", ".join(f"{n} {a}" for a, n in counts.items() if n) or "nothing found"
        skipped = f"; skipped: {', '.join(self.skipped)}" if self.skipped else ""
        return f"RecordReport({found}{skipped})"
