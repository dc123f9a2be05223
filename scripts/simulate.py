"""Simulate sine-sweep tests and write a measured-data set (docs/identify.md).

    python scripts/simulate.py                      # default fin, paper sweep, conf/simulate.yaml
    python scripts/simulate.py model=npz model.path=my_fin.npz levels=[0.4,0.6] noise_std_g=0.1
    python scripts/simulate.py model=sdof debug=fast

The same command as the installed ``freeplayid-simulate`` (:mod:`freeplayid.tasks.cli`).
"""

from freeplayid.tasks.cli import simulate

if __name__ == "__main__":
    simulate()
