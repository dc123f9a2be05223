"""Identify hinge freeplay (kn, delta) from a measured sine-sweep data set (docs/identify.md).

    python scripts/identify.py                              # the bundled example data set
    python scripts/identify.py data=PATH/manifest.yaml      # your data set
    python scripts/identify.py data=PATH fit.backbone=hb fit.n_bootstrap=200 debug=fast

The same command as the installed ``freeplayid-identify`` (:mod:`freeplayid.tasks.cli`).
"""

from freeplayid.tasks.cli import identify

if __name__ == "__main__":
    identify()
