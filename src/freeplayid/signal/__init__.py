"""Output-only first-harmonic extraction and backbone fitting points (plain NumPy arrays).

- :func:`acmp`: adaptive chirp mode pursuit, one chirp mode, banded O(N) solves;
- :func:`lockin`: demodulation with the known sweep phase (reference, baseline);
- :func:`extract_backbone_points`: Eq. 9, base subtraction, resonance peak / jump, rejections;
- :func:`estimate_sweep`: the sweep law (linear or log) of a record without a hint;
- noise helpers for simulated records.
"""

from .acmp import ChirpMode, acmp, bandwidth_weight, narrowest_bandwidth, ridge_frequency
from .extract import (
    AmplitudeCurve,
    BackbonePoint,
    BackbonePoints,
    extract_backbone_points,
    noise_floor,
    to_displacement,
)
from .jump import (
    REASON_EDGE,
    REASON_FAILED,
    REASON_NO_JUMP,
    REASON_NOISY,
    REASON_START,
    find_jump_peak,
    reason_dead,
)
from .level import window_amplitudes
from .lockin import lockin
from .noise import add_noise_for_snr, white_noise
from .options import EXTRACTION_METHODS, Extraction
from .peak import JUMP_POINTS
from .sweeplaw import SweepEstimate, estimate_sweep

__all__ = [
    "ChirpMode",
    "acmp",
    "lockin",
    "window_amplitudes",
    "estimate_sweep",
    "SweepEstimate",
    "ridge_frequency",
    "bandwidth_weight",
    "narrowest_bandwidth",
    "white_noise",
    "add_noise_for_snr",
    "extract_backbone_points",
    "noise_floor",
    "Extraction",
    "EXTRACTION_METHODS",
    "JUMP_POINTS",
    "find_jump_peak",
    "to_displacement",
    "BackbonePoint",
    "BackbonePoints",
    "AmplitudeCurve",
    "REASON_NO_JUMP",
    "REASON_EDGE",
    "REASON_START",
    "REASON_NOISY",
    "REASON_FAILED",
    "reason_dead",
]
