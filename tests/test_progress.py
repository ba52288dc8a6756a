"""Compilation: one progress line on a cold numba cache, none on a warm one; what a cold
first step compiles."""
import json
import os
import subprocess
import sys

from hoprover_env._progress import MESSAGE


def test_one_progress_line_when_compiling_none_when_cached(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    code = "import hoprover_env"          # compiles the explicit-signature kernels
    cold = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True)
    assert cold.stderr.count(MESSAGE) == 1
    warm = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True)
    assert MESSAGE not in warm.stderr


COMPILED = r'''
import json, sys
from numba.core import event
seen = []
class Listener(event.Listener):
    def on_start(self, ev):
        f = getattr(ev.data.get("dispatcher"), "py_func", None)
        seen.append([f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', '?')}",
                     str(ev.data.get("args"))])
    def on_end(self, ev):
        pass
event.register("numba:compile", Listener())
import numpy as np, gymnasium as gym, hoprover_env
env = gym.make(sys.argv[1], **json.loads(sys.argv[2]))
env.reset(seed=0)
env.step(np.array([0.5], np.float32))
print(json.dumps(seen))
'''


def compiled_by_first_step(cache_dir, env_id="HopRover-v0", **kwargs):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    out = subprocess.run([sys.executable, "-c", COMPILED, env_id, json.dumps(kwargs)],
                         env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_cold_first_step_compiles_no_euler_code_and_nothing_twice(tmp_path):
    seen = compiled_by_first_step(tmp_path)
    ours = [name for name, _ in seen if name.startswith("hoprover_env.")]
    assert "hoprover_env.rl_kernel.env_step" in ours and len(ours) > 40
    assert not [n for n in ours if "euler" in n.lower()]
    # each function once: a second specialisation (say for a literal int argument) would
    # compile the function again and relink everything above it
    assert len(ours) == len(set(ours)), sorted(n for n in ours if ours.count(n) > 1)
    # the Euler env compiles its integrator on first use, from the same (warm) cache
    seen = compiled_by_first_step(tmp_path, integrator="euler")
    assert "hoprover_env.core._advance_euler" in [name for name, _ in seen]
