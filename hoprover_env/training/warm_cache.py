"""Warm numba's on-disk cache: `python -m hoprover_env.training.warm_cache`.

Builds and steps every registered environment (the single env and the native vector
env, threaded and not) and runs `simulate` and `simulate_batch` with both integrators
(the event one on smooth and on rough ground) once, which compiles every kernel into
numba's cache; it also runs one short episode of the scripted hopper and of a bundled
learned policy (hoprover_env.agents). Every later process on the machine, a Ray
worker included, loads the compiled code instead of compiling it (10-16 s per process
on a cold cache).

The cache is where numba keeps it for the imported hoprover: the package's
__pycache__ folders when they are writable (an editable install: the checkout), else
numba's per-user cache folder, or NUMBA_CACHE_DIR when that is set. Run this as the
user and with the same NUMBA_CACHE_DIR as the processes that will use the cache, on
the same CPU model (numba compiles for the host CPU): in a container build after
installing hoprover, or in a cluster's node setup step. It prints what it compiled and
what it found already compiled.
"""

from __future__ import annotations

import argparse
import gc
import sys
import time


def compile_counts() -> tuple[dict[str, int], int]:
    """({function name: signatures compiled in this process}, signatures loaded from the
    cache) over every numba function this process has seen."""
    from numba.core.dispatcher import Dispatcher

    compiled, loaded = {}, 0
    for obj in gc.get_objects():
        if isinstance(obj, Dispatcher):
            stats = obj.stats
            misses = sum(stats.cache_misses.values())
            if misses:
                name = f"{obj.py_func.__module__}.{obj.py_func.__qualname__}"
                compiled[name] = compiled.get(name, 0) + misses
            loaded += sum(stats.cache_hits.values())
    return compiled, loaded


def warm(log=None) -> None:
    """Compile (or load) every kernel once."""
    import gymnasium as gym
    import numpy as np

    from hoprover_env import RoverParams, simulate, simulate_batch
    from hoprover_env.envs import registry as _registry

    say = log or (lambda msg: None)
    for env_id in _registry.ENVS:
        t0 = time.perf_counter()
        env = gym.make(env_id)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
        for threads in (False, True):
            vec = _registry.vector_env_class(env_id)(num_envs=2, threads=threads)
            vec.reset(seed=0)
            vec.step(vec.action_space.sample())
            vec.close()
        say(f"  {env_id}: {time.perf_counter() - t0:.1f} s")
    # each integrator, and the event integrator on rough ground too: the loops of simulate
    # and simulate_batch are compiled per kind of run (sim/control_loop.py, loop_kind)
    for integrator, params in (
        ("event", None),
        ("event", RoverParams(roughness=0.1)),
        ("euler", None),
    ):
        t0 = time.perf_counter()
        simulate(
            np.full(10, 3e-4),
            t_end=5.0,
            control_dt=0.5,
            integrator=integrator,
            params=params,
            seed=0,
        )
        simulate_batch(
            np.full((2, 10), 3e-4),
            np.array([0.5, -0.5]),
            t_end=5.0,
            control_dt=0.5,
            integrator=integrator,
            params=params,
            seed=0,
        )
        ground = "smooth" if params is None else "rough"
        say(
            f"  simulate, simulate_batch ({integrator}, {ground} ground): "
            f"{time.perf_counter() - t0:.1f} s"
        )
    # the layers above this one, imported here so that the cache warms without them
    from hoprover_env.agents.policies import load_policy
    from hoprover_env.evaluation.episodes import run_episodes

    for name in ("scripted", "scratch"):
        t0 = time.perf_counter()
        run_episodes(load_policy(name, control_dt=0.5), np.array([0.5]))
        say(f"  agents: one {name} episode: {time.perf_counter() - t0:.1f} s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n", 2)[2],
    )
    ap.parse_args(argv)
    from numba.core.config import CACHE_DIR

    from hoprover_env.util.buildinfo import build_info

    info = build_info()
    print(
        f"hoprover {info['version']} (source {info['source']}, commit {info['commit']}) "
        f"at {info['path']}; numba cache: {CACHE_DIR or 'beside the sources'}",
        file=sys.stderr,
    )
    t0 = time.perf_counter()
    warm(log=lambda msg: print(msg, file=sys.stderr))
    compiled, loaded = compile_counts()
    print(
        f"compiled {sum(compiled.values())} function signatures, loaded {loaded} from "
        f"the cache, in {time.perf_counter() - t0:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
