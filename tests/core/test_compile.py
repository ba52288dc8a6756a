"""Compilation (hoprover_env/jit/compiler.py): one progress line on a cold numba cache, none
on a warm one; what a cold first step compiles, in one process or with the
parallel-compile helper (a fresh interpreter, never a fork); the fallback to plain numba
when its internals are missing. (An edited task module compiling afresh:
tests/tasks/test_task_recompiles.py.)"""

import json
import os
import re
import shutil
import subprocess
import sys
import time

import pytest

from hoprover_env.jit.compiler import MESSAGE

# cold compiles in fresh interpreters: minutes in all
pytestmark = pytest.mark.slow


def test_one_progress_line_when_compiling_none_when_cached(tmp_path, cold_serial):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    # importing compiles nothing (declared signatures compile on first use)
    bare = subprocess.run(
        [sys.executable, "-c", "import hoprover_env"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert MESSAGE not in bare.stderr
    assert not list(tmp_path.rglob("*.nbi"))
    # a cold first step says it compiles, once; the same steps on its cache say nothing
    assert cold_serial[1]["messages"] == 1
    shutil.copytree(cold_serial[0], tmp_path, dirs_exist_ok=True)
    assert first_steps(tmp_path)["messages"] == 0


COMPILED = r"""
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
obs0, _ = env.reset(seed=0)
obs, reward, *_ = env.step(np.array([0.5], np.float32))
for _ in range(30):
    obs, reward, *_ = env.step(np.array([-0.3], np.float32))
print(json.dumps({"compiled": seen, "obs": obs.tolist(), "reward": reward}))
"""


def first_steps(cache_dir, env_id="HopRover-v0", parallel="0", **kwargs):
    """What a fresh interpreter compiled for its first steps, and where they ended
    (`parallel`: HOPROVER_PARALLEL_COMPILE)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), HOPROVER_PARALLEL_COMPILE=parallel)
    out = subprocess.run(
        [sys.executable, "-c", COMPILED, env_id, json.dumps(kwargs)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return {
        **json.loads(out.stdout.strip().splitlines()[-1]),
        "messages": out.stderr.count(MESSAGE),
    }


def compiled_by_first_step(cache_dir, env_id="HopRover-v0", **kwargs):
    return first_steps(cache_dir, env_id, **kwargs)["compiled"]


STEP_KERNEL = r"hoprover_env\.tasks\.common\.torque_event_smooth_step_[0-9a-f]{16}"

# the rough ground's own code: its counter-based generator (philox4x64) is not in this list,
# since every env's episode draws use it too (tasks/draws.py)
ROUGH_TERRAIN_CODE = (
    "hoprover_env.core.terrain.impact_tilt",
    "hoprover_env.core.terrain.truncated_normal",
    "hoprover_env.core.impacts._rotate_velocity",
    "hoprover_env.core.impacts._stop_on_mean_plane",
)


@pytest.fixture(scope="module")
def cold_serial(tmp_path_factory):
    """One cold first step of HopRover-v0 compiled in one process (no helper), which two
    tests compare against: (its cache folder, what it compiled and where it ended)."""
    cache = tmp_path_factory.mktemp("cold-serial")
    return cache, first_steps(cache)


def test_a_cold_first_step_compiles_no_euler_code_and_nothing_twice(tmp_path, cold_serial):
    seen = cold_serial[1]["compiled"]
    shutil.copytree(cold_serial[0], tmp_path, dirs_exist_ok=True)  # its cache, warmed
    ours = [name for name, _ in seen if name.startswith("hoprover_env.")]
    # the env's step kernel, named for a digest of its sources (jit.compiler.bind)
    assert [n for n in ours if re.fullmatch(STEP_KERNEL, n)] and len(ours) > 40
    assert not [n for n in ours if "euler" in n.lower()]
    # on smooth ground no rough-terrain code (core/smooth.py): no tilt draws, no tilted
    # impacts; a terrain env compiles them, from the same cache
    assert not [n for n in ours if n.startswith(ROUGH_TERRAIN_CODE)]
    rough = [name for name, _ in compiled_by_first_step(tmp_path, "HopRoverTerrain-v0")]
    assert "hoprover_env.core.terrain.impact_tilt" in rough
    assert "hoprover_env.core.impacts._stop_on_mean_plane" in rough
    # each function once: a second specialisation (say for a literal int argument) would
    # compile the function again and relink everything above it
    assert len(ours) == len(set(ours)), sorted(n for n in ours if ours.count(n) > 1)
    # the Euler env compiles its integrator on first use, from the same (warm) cache
    seen = compiled_by_first_step(tmp_path, integrator="euler")
    assert "hoprover_env.core.euler.advance_euler" in [name for name, _ in seen]


def test_the_parallel_compile_helper_does_the_contact_phases_and_changes_nothing(
    tmp_path, cold_serial
):
    # on a cold cache a helper process (a fresh interpreter; any value of the switch but
    # "0" starts it, "spawn", its old name, too) takes the contact phases off the queue
    # while this process compiles the end of a phase; the env step then loads them from
    # the cache
    from hoprover_env.jit import compiler as pc

    if pc._cores() < 2:
        pytest.skip("the helper only starts with two or more cores")
    serial = cold_serial[1]
    parallel = first_steps(tmp_path / "parallel", parallel="1")
    main = [name for name, _ in parallel["compiled"] if name.startswith("hoprover_env.")]
    everything = [name for name, _ in serial["compiled"] if name.startswith("hoprover_env.")]
    # the first of the queue: taken by the helper while this process is at the end of a
    # phase (the rest of the queue goes to whichever process is free first)
    helper_only = {
        "hoprover_env.core.contact_phases.contact_phase",
        "hoprover_env.core.contact_steps._dop853_step",
        "hoprover_env.core.contact_steps._locate",
    }
    assert "hoprover_env.core.smooth.after_phase_smooth" in main
    assert helper_only <= set(everything)
    assert not helper_only & set(main), sorted(helper_only & set(main))
    assert [n for n in main if re.fullmatch(STEP_KERNEL, n)]
    assert len(main) == len(set(main)) and len(main) < len(everything) - 10
    # the same machine code: identical trajectories, bit for bit
    assert parallel["obs"] == serial["obs"] and parallel["reward"] == serial["reward"]
    cached = {p.name.split("-")[0] for p in (tmp_path / "parallel").rglob("*.nbi")}
    assert {"contact_phases.contact_phase", "contact_phases.g_phase"} <= cached
    assert not list((tmp_path / "parallel").rglob("*.lock"))


def test_each_function_of_the_queue_is_compiled_by_one_process(tmp_path, monkeypatch):
    from hoprover_env.jit import compiler as pc

    compiled = []
    monkeypatch.setattr(pc, "_resolve", lambda names: list(names))
    monkeypatch.setattr(pc, "compile_now", compiled.append)
    queue = (str(tmp_path), "m:a", "m:b", "m:c")
    (tmp_path / "1").touch()  # the other process took "m:b"
    pc.compile_queue(queue)
    assert compiled == ["m:a", "m:c"]
    pc.compile_queue(queue)  # a second taker finds nothing left
    assert compiled == ["m:a", "m:c"]


def _no_helper(started):
    def start(names):  # records the start; the helper "fails to start"
        started.append(1)

    return start


def test_the_helper_is_skipped_on_a_warm_cache_and_when_switched_off(tmp_path, monkeypatch):
    from hoprover_env.jit import compiler as pc
    from hoprover_env.tasks import torque

    started = []
    monkeypatch.setattr(pc, "_start_helper", _no_helper(started))
    monkeypatch.setattr(pc, "_prepared", False)
    monkeypatch.setenv(pc.ENV_SWITCH, "0")
    pc.prepare()
    monkeypatch.setattr(pc, "_prepared", False)
    monkeypatch.setenv(pc.ENV_SWITCH, "1")
    for d in pc.QUEUE + pc.QUEUE_END + torque.TASK.compile_extra:  # compiled here
        pc.compile_now(d)
    pc.prepare(torque.TASK.compile_extra)
    assert started == []


def test_one_helper_per_cache_at_a_time(tmp_path, monkeypatch):
    # many workers starting at once on a cold cache (a cluster node) start one helper,
    # not one each; a lock left behind by a killed process does not block for ever

    from hoprover_env.jit import compiler as pc

    class Cache:
        cache_path = str(tmp_path)

    class Dispatcher:
        _cache = Cache()
        py_func = _no_helper

    started = []
    monkeypatch.setattr(pc, "_start_helper", _no_helper(started))
    monkeypatch.setattr(pc, "_cached", lambda d: False)
    monkeypatch.setattr(pc, "_cores", lambda: 2)
    monkeypatch.setattr(pc, "QUEUE", (Dispatcher(),))
    monkeypatch.setenv(pc.ENV_SWITCH, "1")
    monkeypatch.delenv(pc._HELPER_FLAG, raising=False)
    lock = tmp_path / "hoprover-compile-helper.lock"
    lock.touch()
    monkeypatch.setattr(pc, "_prepared", False)
    pc.prepare()
    assert started == []  # another process's helper is at work
    old = time.time() - 2 * pc.HELPER_TIMEOUT
    os.utime(lock, (old, old))
    monkeypatch.setattr(pc, "_prepared", False)
    pc.prepare()
    assert started == [1] and not lock.exists()


RUN = r"""
import numpy as np
from numba import njit
from hoprover_env import RoverParams, simulate
from hoprover_env.sim.controllers import attitude_hold
INERTIA = RoverParams().inertia

@njit
def hopper(pos, vel, the, omg, posT, t, smt, state):   # launch, hold the attitude, land
    if state == 0:
        return attitude_hold(the, omg, INERTIA, 0.15, 0.9)
    return 3e-4 if t < 3.0 else 0.0

roll = simulate(hopper, t_end=300.0, control_dt=0.5, target_x=0.3)
"""

HIDDEN = (
    r"""
import warnings
import numba.core.registry, numba.core.caching
# a numba release that moved the internals hoprover's compile layer uses
del numba.core.registry.CPUDispatcher
for cls in numba.core.caching.FunctionCache.__mro__:
    if "cache_path" in vars(cls):
        delattr(cls, "cache_path")
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
"""
    + "\n".join("    " + line for line in RUN.splitlines())
    + r"""
print(any("falling back to plain numba" in str(w.message) for w in caught))
print(repr(roll.x[-1]), repr(roll.t[-1]), roll.state[-1], len(roll.events))
"""
)


def test_without_the_numba_internals_it_falls_back_to_plain_numba(tmp_path):
    # the fallback compiles with plain numba.njit(cache=True), warns once, and runs the
    # same physics: the same rollout as the compile layer gives, bit for bit
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), HOPROVER_PARALLEL_COMPILE="0")
    out = subprocess.run(
        [sys.executable, "-c", HIDDEN], env=env, capture_output=True, text=True, timeout=900
    )
    assert out.returncode == 0, out.stderr[-2000:]
    warned, result = out.stdout.strip().splitlines()[-2:]
    assert warned == "True"
    here = {}
    exec(RUN, here)
    roll = here["roll"]
    assert result == f"{roll.x[-1]!r} {roll.t[-1]!r} {roll.state[-1]} {len(roll.events)}"
    # it hopped and landed: the run exercises flight, impacts and contact phases
    assert len(roll.impact_energy_ratios) > 0 and roll.state[-1] != "A"


def test_a_helper_that_hangs_is_waited_for_then_killed(tmp_path, monkeypatch):
    # prepare() waits for the helper at most HELPER_TIMEOUT, then kills it, removes its
    # lock and marks, and leaves what the helper did not finish to the first use here
    from hoprover_env.jit import compiler as pc

    class Cache:
        cache_path = str(tmp_path)

    class Dispatcher:
        _cache = Cache()
        py_func = _no_helper

    helpers, compiled = [], []

    def start(queue):
        helpers.append(subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"]))
        return helpers[-1]

    monkeypatch.setattr(pc, "_start_helper", start)
    monkeypatch.setattr(pc, "_cached", lambda d: False)
    monkeypatch.setattr(pc, "_cores", lambda: 2)
    monkeypatch.setattr(pc, "AFTER_PHASE", {True: Dispatcher(), False: Dispatcher()})
    monkeypatch.setattr(pc, "QUEUE", (Dispatcher(),))
    monkeypatch.setattr(pc, "_resolve", lambda names: [Dispatcher()] * len(names))
    monkeypatch.setattr(pc, "compile_now", compiled.append)
    monkeypatch.setattr(pc, "HELPER_TIMEOUT", 0.5)
    monkeypatch.setattr(pc, "_prepared", False)
    monkeypatch.delenv(pc.ENV_SWITCH, raising=False)
    monkeypatch.delenv(pc._HELPER_FLAG, raising=False)
    started = time.monotonic()
    pc.prepare()
    assert time.monotonic() - started < 30
    assert len(helpers) == 1 and helpers[0].returncode == -9
    assert compiled and not list(tmp_path.iterdir())  # the lock is gone


def test_the_layers_tell_the_compiler_what_it_compiles_and_hashes():
    # the compiler names no module above its own: the package adds the kernel sources
    # before the first kernel (hoprover_env/_kernel_sources.py) and core registers the
    # parts of the parallel cold compile (core/smooth.py)
    import hoprover_env
    from hoprover_env.core import contact_phases, smooth
    from hoprover_env.jit import compiler as pc

    root = os.path.dirname(hoprover_env.__file__)
    for name in (
        "core/integrator.py",
        "tasks/common.py",
        "jit/compiler.py",
        "sim/control_loop.py",
        "sim/controllers.py",
    ):
        assert os.path.join(root, name) in pc.KERNEL_SOURCES
    assert os.path.join(root, "sim/simulate.py") not in pc.KERNEL_SOURCES
    assert pc.AFTER_PHASE[False] is smooth.after_phase_smooth
    assert pc.QUEUE[0] is contact_phases.contact_phase
    assert pc._resolve([pc._reference(d) for d in pc.QUEUE]) == list(pc.QUEUE)
    with pytest.raises(RuntimeError):  # too late: kernels are built already
        pc.add_kernel_sources([__file__])
