"""Train an SB3 agent on the native batched HopRover environment.

The command `hoprover-train` (installed with the package); this file runs it from a
checkout as `python train.py`. The code and its full description: hoprover_env/training/train.py.
"""

import sys

from hoprover_env.training.train import main

if __name__ == "__main__":
    sys.exit(main())
