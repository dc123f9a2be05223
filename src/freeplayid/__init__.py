"""freeplayid: output-only identification of hinge freeplay in folding fins from sine sweeps.

Submodules (imported on demand so ``import freeplayid`` stays light): ``model``, ``simulate``,
``signal``, ``backbone``, ``fit``, ``inverse``, ``studies``, ``io``, ``plots``, ``tasks``.
"""

__version__ = "0.1.0"
