"""freeplayid: output-only identification of hinge freeplay in folding fins from sine sweeps.

    from freeplayid import identify
    from freeplayid.io import read_dataset

    result = identify(read_dataset("examples/fin_sweeps"))

Submodules (imported on demand so ``import freeplayid`` stays light: no torch, Lightning or
Hydra): ``model``, ``simulate``, ``signal``, ``backbone``, ``fit``, ``inverse``, ``studies``,
``io``, ``plots``, ``tasks``; the pipeline :func:`identify` and its :class:`Identification`
live in ``identification``.
"""

__version__ = "0.1.0"

__all__ = ["identify", "Identification", "IdentificationError", "InputError",
           "read_identification", "Dataset", "__version__"]

_LAZY = {
    "identify": "identification",
    "Identification": "identification",
    "IdentificationError": "identification",
    "read_identification": "identification",
    "InputError": "errors",
    "Dataset": "dataset",  # Dataset.from_arrays: a data set from a notebook's arrays
}


def __getattr__(name: str):
    # the pipeline imports SciPy; load it on first use, not on `import freeplayid`
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
