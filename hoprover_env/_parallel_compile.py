"""Compile the kernel in two processes at once when numba's cache is cold.

numba compiles one function at a time, in one process, holding the GIL: the first
environment step after installing costs 10-16 s on one core while the others idle. The
core's phases are independent of each other until the integrator's loop links them, so
on a cold cache `prepare()` starts one helper process that compiles the contact phases
(state G, states B-E by DOP853; for the envs also the reward and observation code) into
numba's on-disk cache, while this process compiles flight, what follows a phase
(transitions, impacts, the judge) and the initial-state classification. It then waits
for the helper; the caller's own kernel (env step, run loop) loads the helper's
functions from the cache when it links them, as it would on any warm start. The
compiled code is the same either way: a function loaded from the cache is the one the
helper compiled from the same source with the same numba (tests/test_progress.py runs
both ways and compares the trajectories bit for bit).

Nothing happens when the cache already holds the helper's functions (every start after
the first), on a single core, inside the helper itself, while another process's helper
is working on the same cache (many workers starting at once on a cluster node: one
helper, not one per worker), or with HOPROVER_PARALLEL_COMPILE=0 in the environment. If
the helper cannot start, fails or hangs, this process compiles everything itself, as
numba normally would.
"""
from __future__ import annotations

import importlib
import os
import subprocess
import sys
import time

from .core._jit import compile_declared

ENV_SWITCH = "HOPROVER_PARALLEL_COMPILE"     # "0" turns the helper off
_HELPER_FLAG = "_HOPROVER_COMPILE_HELPER"     # set in the helper's environment
HELPER_TIMEOUT = 120.0                        # s; a helper taking longer is killed
_prepared = False


def helper_functions(extra=()):
    """What the helper compiles: the contact phases (G in closed form, B-E by DOP853),
    about a third of the core's compile time, and the caller's `extra` functions
    ("module:name", declared signatures)."""
    from .core import contact_phases
    return [contact_phases.contact_phase, contact_phases.g_phase] + [
        getattr(importlib.import_module(name.split(":")[0]), name.split(":")[1])
        for name in extra]


def main_functions():
    """What this process compiles meanwhile (while the helper also pays for starting
    Python): the end of a phase (transitions, impacts, judge), flight and the
    initial-state classification."""
    from .core import flight, integrator, phase_end
    return [phase_end._after_phase, flight.flight_phase, integrator.init_state]


def _cached(dispatcher) -> bool:
    """Compiled in this process, or in numba's cache for the current source."""
    if dispatcher.overloads:
        return True
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:           # noqa: BLE001 - caching off, or another numba layout:
        return True             # then a helper could not share its work; do not start it


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # macOS, Windows
        return os.cpu_count() or 1


def _claim(dispatcher):
    """A lock file beside the cache, so that one helper works on it at a time; None if
    another process holds it (a lock older than HELPER_TIMEOUT is left over: taken)."""
    try:
        path = os.path.join(dispatcher._cache._cache_path, "hoprover-compile-helper.lock")
    except AttributeError:
        return None
    for _ in range(2):
        try:
            os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            return path
        except FileExistsError:
            try:
                if time.time() - os.path.getmtime(path) < HELPER_TIMEOUT:
                    return None
                os.remove(path)
            except OSError:
                return None
        except OSError:             # a read-only cache directory, say
            return None
    return None


def _start_helper(extra=()):
    # the helper must compile this very package, wherever it was imported from
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.pathsep.join(p for p in (package_parent, os.environ.get("PYTHONPATH")) if p)
    env = dict(os.environ, PYTHONPATH=path, **{_HELPER_FLAG: "1"})
    try:
        return subprocess.Popen(
            [sys.executable, "-c",
             "import sys; from hoprover_env import _parallel_compile as p; p.helper(sys.argv[1:])",
             *extra],
            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
    except OSError:
        return None


def prepare(extra=()) -> None:
    """Called by every entry point (envs, simulate, simulate_batch) before its first kernel
    call; returns at once after the first call in a process. `extra`: more functions for
    the helper ("module:name", with declared signatures), such as an env's reward and
    observation code."""
    global _prepared
    if _prepared:
        return
    _prepared = True
    if os.environ.get(_HELPER_FLAG) or os.environ.get(ENV_SWITCH, "1") == "0" or _cores() < 2:
        return
    functions = helper_functions(extra)
    if all(_cached(d) for d in functions):
        return
    lock = _claim(functions[0])
    if lock is None:
        return
    try:
        helper = _start_helper(extra)
        if helper is not None:
            _compile_beside(helper)
    finally:
        try:
            os.remove(lock)
        except OSError:
            pass


def _compile_beside(helper) -> None:
    """Compile this process's part, then wait for the helper (killed if it hangs)."""
    started = time.monotonic()
    try:
        for d in main_functions():
            compile_declared(d)
        helper.wait(timeout=max(0.0, started + HELPER_TIMEOUT - time.monotonic()))
    except subprocess.TimeoutExpired:
        pass                    # this process compiles what the helper did not finish
    finally:
        if helper.poll() is None:
            helper.kill()
            helper.wait()


def helper(extra=()) -> None:
    """The helper process: compile its functions into the cache and exit."""
    for d in helper_functions(extra):
        compile_declared(d)
