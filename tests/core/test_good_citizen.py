"""hoprover is a good citizen of the process that imports it: importing it, making and
stepping every registered env (single and threaded vector), simulate and simulate_batch
leave numba, llvmlite, OpenMP, torch, the environment, warnings and signal handlers as
they were (docs/COMPILING.md). Each check runs in a fresh interpreter, so that nothing an
earlier test did is taken for hoprover's doing."""

import json
import os
import subprocess
import sys

import pytest

# the fast tier (pytest -m "not slow") leaves this file out: fresh interpreters make
# and step every registered env
pytestmark = pytest.mark.slow


# What the process holds before hoprover is imported, compared after it ran. hoprover's
# dependencies are imported first: what importing them does (gymnasium adds warnings
# filters, numpy starts its BLAS threads) is theirs, and a user of a Gymnasium env
# imports gymnasium anyway. The user here has started numba's threads
# (numba.get_num_threads) and set torch to one thread afterwards, as a training script
# does; numba's OpenMP layer would set it back to numba's count at every threaded launch.
PROBE = r"""
import ctypes, faulthandler, json, logging, os, signal, sys, threading, warnings
import numpy as np
import gymnasium as gym
import numba
from numba.core import codegen, compiler, errors, event, ir, targetconfig
from llvmlite.binding import ffi
try:
    import torch
except ImportError:
    torch = None

numba_threads = numba.get_num_threads()          # starts numba's threading layer
if torch is not None:
    torch.set_num_threads(1)

CLASSES = {"JITCodeLibrary": codegen.JITCodeLibrary, "JITCPUCodegen": codegen.JITCPUCodegen,
           "TargetConfig": targetconfig.TargetConfig, "Flags": compiler.Flags,
           "ir.Inst": ir.Inst,
           "HighlightColorScheme": getattr(errors, "HighlightColorScheme", object)}


def openmp():
    try:
        lib = ctypes.CDLL("libgomp.so.1", mode=os.RTLD_NOLOAD)
    except OSError:
        return None
    return lib.omp_get_max_threads(), lib.omp_get_max_active_levels()


def state():
    out = {f"{name}.{attr}": value for name, cls in CLASSES.items()
           for attr, value in vars(cls).items()}
    out.update({
        "llvm lock callbacks": list(ffi.lib._lock._cblist),
        "numba event listeners": {k: list(v) for k, v in event._registered.items() if v},
        "numba.config": {k: getattr(numba.config, k) for k in dir(numba.config)
                         if k.isupper()},
        "numba.get_num_threads()": numba.get_num_threads(),
        "numba.threading_layer()": numba.threading_layer(),
        "torch.get_num_threads()": torch.get_num_threads() if torch is not None else None,
        "OpenMP (threads, max active levels)": openmp(),
        "os.environ": dict(os.environ),
        "warnings.filters": list(warnings.filters),
        "signal handlers": {s.name: signal.getsignal(s) for s in signal.valid_signals()
                            if isinstance(s, signal.Signals)},
        "numpy error handling": np.geterr(),
        "recursion limit": sys.getrecursionlimit(),
        "excepthook": sys.excepthook,
        "faulthandler": faulthandler.is_enabled(),
        "cwd": os.getcwd(),
        "root logger": (logging.root.level, list(logging.root.handlers)),
        "python threads": threading.active_count(),
    })
    return out


before = state()

import hoprover_env
from hoprover_env import simulate, simulate_batch

ran = []
for env_id in hoprover_env.ENVS:
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(2):
        env.step(env.action_space.sample())
    env.close()
    vec = gym.make_vec(env_id, num_envs=64, vectorization_mode="vector_entry_point",
                       threads=True)
    assert getattr(vec, "unwrapped", vec).threads
    vec.reset(seed=0)
    vec.action_space.seed(0)
    for _ in range(2):
        vec.step(vec.action_space.sample())
    vec.close()
    ran.append(env_id)
simulate([3e-4, 0.0, 0.0], t_end=5.0, control_dt=0.5)
simulate_batch(np.zeros((8, 4)), np.full(8, 0.5), t_end=2.0, control_dt=0.5)
ran += ["simulate", "simulate_batch"]

after = state()
changed = sorted(k for k in before.keys() | after.keys()
                 if k not in before or k not in after or before[k] != after[k])
print(json.dumps({"ran": ran, "changed": changed,
                  "detail": {k: [repr(before.get(k))[:300], repr(after.get(k))[:300]]
                             for k in changed}}))
"""


def _probe(extra_env=None, code=PROBE, timeout=1800):
    env = {k: v for k, v in os.environ.items() if not k.startswith("HOPROVER_")}
    env.update(extra_env or {})
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=timeout
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_hoprover_leaves_numba_llvmlite_openmp_torch_env_warnings_and_signals_alone():
    import hoprover_env

    result = _probe()
    # the package's own ids (an earlier test in this process may have added a toy task)
    ours = [i for i, task in hoprover_env.ENVS.items() if task.module.startswith("hoprover_env.")]
    assert result["ran"] == ours + ["simulate", "simulate_batch"]
    assert result["changed"] == [], json.dumps(result["detail"], indent=1)


NUMBA_CLASSES = r"""
import json
from numba.core import codegen, ir, targetconfig
from llvmlite.binding import ffi
def methods():
    return {"finalize": codegen.JITCodeLibrary.finalize,
            "set_env": codegen.JITCPUCodegen.set_env,
            "hash": targetconfig.TargetConfig.__hash__, "list_vars": ir.Inst._rec_list_vars,
            "callbacks": len(ffi.lib._lock._cblist)}
before = methods()
import hoprover_env
from hoprover_env import core
from hoprover_env.jit.compiler import compile_now
compile_now(core.corner_offset)              # kernels declared, one compiled
after = methods()
print(json.dumps({"replaced": sorted(k for k in before if before[k] != after[k])}))
"""


def test_numbas_compiler_classes_are_left_as_they_are(tmp_path):
    # hoprover compiles with numba as it is: declaring kernels and compiling one replaces
    # no method of numba's compiler classes and no callback around llvmlite's lock
    result = _probe({"NUMBA_CACHE_DIR": str(tmp_path)}, NUMBA_CLASSES, timeout=300)
    assert result["replaced"] == []


FIRST_LAUNCH = r"""
import ctypes, json, os
import numpy as np
import torch
torch.set_num_threads(1)
def openmp():
    lib = ctypes.CDLL("libgomp.so.1", mode=os.RTLD_NOLOAD)
    return [lib.omp_get_max_threads(), lib.omp_get_max_active_levels()]
before = [torch.get_num_threads(), openmp()]
import hoprover_env
from numba.np.ufunc import parallel
assert not parallel._is_initialized         # numba's threads start in the env's step
venv = hoprover_env.HopRoverVectorEnv(64, threads=True)
venv.reset(seed=0)
venv.step(np.zeros((64, 1)))
print(json.dumps({"before": before, "after": [torch.get_num_threads(), openmp()]}))
"""


def test_the_first_threaded_step_leaves_torch_and_openmp_as_they_were():
    # numba's OpenMP layer starts inside the first threaded step and sets the caller's
    # OpenMP thread count and the runtime's nesting level; run_threaded puts them back
    pytest.importorskip("torch")
    result = _probe(code=FIRST_LAUNCH, timeout=900)
    assert result["after"] == result["before"]
