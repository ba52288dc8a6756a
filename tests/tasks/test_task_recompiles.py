"""A task module edited between two processes is compiled afresh, not loaded from numba's
cache: the kernels tasks/common.py builds from a task (its step and observation bound
into the single env's step and the vector env's loops) are named for a digest of the
source files of everything they embed (jit.compiler.bind), since numba keys a cached
function on its own file and bytecode only. The task here lives outside the package, as a
researcher's copy of tests/toy_task.py would, renamed so that its kernels and the toy
task's never share a name. The processes use the test session's numba cache, as the
researcher's warm one: the simulator loads from it, the task's kernels compile."""

import json
import os
import pathlib
import re
import subprocess
import sys

import pytest

# the task's kernels compile three times, in fresh interpreters
pytestmark = pytest.mark.slow

TOY = pathlib.Path(__file__).parents[1] / "toy_task.py"

RUN = r"""
import json, numpy as np, gymnasium as gym, hoprover_env
from numba.core import event
compiled = []
class Listener(event.Listener):
    def on_start(self, ev):
        f = getattr(ev.data.get("dispatcher"), "py_func", None)
        compiled.append(f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', '?')}")
    def on_end(self, ev):
        pass
event.register("numba:compile", Listener())
(env_id,) = hoprover_env.register_task("my_task")
env = gym.make(env_id)
env.reset(seed=0)
obs, reward, *_ = env.step(np.array([0.5], np.float32))
out = {"single": [float(reward), obs.tolist()]}
for threads in (False, True):
    venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point",
                        threads=threads)
    venv.reset(seed=0)
    vobs, vreward, *_ = venv.step(np.full((2, 1), 0.5, np.float32))
    out[f"vector threads={threads}"] = [float(vreward[0]), vobs[0].tolist()]
out["compiled"] = compiled
# where numba caches the kernels tasks/common.py builds (NUMBA_CACHE_DIR or in the tree)
import hoprover_env.tasks.common as common
from numba.core.caching import CacheImpl
def probe():
    pass
for locator in CacheImpl._locator_classes:
    found = locator.from_function(probe, common.__file__)
    if found is not None:
        out["cache"] = found.get_cache_path()
        break
print(json.dumps(out))
"""


def _run(folder):
    env = dict(
        os.environ,
        HOPROVER_PARALLEL_COMPILE="0",
        PYTHONPATH=os.pathsep.join(p for p in (str(folder), os.environ.get("PYTHONPATH")) if p),
    )
    out = subprocess.run(
        [sys.executable, "-c", RUN],
        env=env,
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=1500,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _edit(path, old, new):
    text = path.read_text()
    assert text.count(old) == 1, old
    path.write_text(text.replace(old, new))


def test_an_edited_task_module_is_recompiled_for_the_single_and_the_vector_env(tmp_path):
    folder = tmp_path / "research"
    folder.mkdir()
    task = folder / "my_task.py"
    task.write_text(TOY.read_text())
    _edit(task, 'name="toy_tip"', 'name="my_tip"')
    first = _run(folder)
    kinds = ("single", "vector threads=False", "vector threads=True")
    reward, obs = first["single"]
    assert reward < 0.0
    for kind in kinds:
        assert first[kind] == [reward, obs], kind

    # the researcher multiplies the reward by 100 and halves the first observation
    line = re.search(r"^    reward = (.*)$", task.read_text(), re.M)
    assert line, "the toy task's step no longer computes `reward = ...` on one line"
    _edit(task, line.group(0), f"    reward = 100.0 * ({line.group(1)})")
    _edit(task, "obs[0] = math.sin(S[S_TH])", "obs[0] = 0.5 * math.sin(S[S_TH])")
    second = _run(folder)
    for kind in kinds:
        new_reward, new_obs = second[kind]
        assert new_reward == pytest.approx(100.0 * reward, rel=1e-12), kind
        assert new_obs[0] == pytest.approx(0.5 * obs[0], rel=1e-6), kind
        assert new_obs[1:] == obs[1:], kind
    # only what the edit touched compiled again: the simulator came from the cache
    assert not [name for name in second["compiled"] if name.startswith("hoprover_env.core")]
    # and the cache of the edited task is used: a third run compiles none of its kernels
    third = _run(folder)
    for kind in kinds:
        assert third[kind] == second[kind], kind
    assert not [name for name in third["compiled"] if "my_tip" in name], third["compiled"]
    assert [name for name in first["compiled"] if "my_tip" in name]
    # the first version's kernels were deleted from the cache when the second was built
    cache = pathlib.Path(third["cache"])
    steps = {p.name.split("-")[0] for p in cache.glob("common.my_tip_*_step_*.nbi")}
    assert len(steps) == 1, steps
