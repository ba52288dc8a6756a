"""Write tests/data/flat_baseline.npz: the flat-ground results of tests/flat_cases.py as
the code before terrain (commit 6fc532c) gives them.

    git worktree add --detach ../flat-base 6fc532c
    cd ../flat-base && PYTHONPATH=.:$OLDPWD/tests python $OLDPWD/tests/data/make_flat_baseline.py

(run from the checkout's root: $OLDPWD is the checkout after the cd)

It refuses to run on code that already knows about terrain (RoverParams.slope)."""

import os
import sys

import numpy as np

import hoprover_env
from flat_cases import cases, record
from hoprover_env import RoverParams, simulate

if hasattr(RoverParams(), "slope"):
    sys.exit("run this on the baseline commit (6fc532c), not on code with terrain")
out = {}
for name, (ctrl, kw) in cases().items():
    for key, value in record(simulate(ctrl, **kw)).items():
        out[f"{name}/{key}"] = value
path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "flat_baseline.npz")
tmp = path + ".tmp.npz"
np.savez_compressed(tmp, **out)
os.replace(tmp, path)
print(
    f"{len(cases())} cases from {os.path.dirname(hoprover_env.__file__)} -> {path} "
    f"({os.path.getsize(path) / 1e3:.0f} kB)"
)
