"""Hyperparameter and seed sweeps of train.py's trainer on Ray Tune.

The command `hoprover-sweep` (installed with the package); this file runs it from a
checkout as `python sweep.py`. The code and its full description: hoprover_env/training/sweep.py.
"""

import sys

from hoprover_env.training.sweep import main

if __name__ == "__main__":
    sys.exit(main())
