"""Evaluate policies with the contest judge on a fixed, seeded set of random targets.

The command `hoprover-evaluate` (installed with the package); this file runs it from a
checkout as `python evaluate.py`. The code and its full description:
hoprover_env/training/evaluate.py.
"""

import sys

from hoprover_env.training.evaluate import main

if __name__ == "__main__":
    sys.exit(main())
