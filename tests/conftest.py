import os
import subprocess
import sys
import time

from hypothesis import HealthCheck, settings

# CI draws the same examples every run (a fixed budget, no flakes); "thorough" explores
settings.register_profile(
    "ci",
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "thorough", max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# HOPROVER_TEST_WARMUP=0 skips the warm-up below (a cache known to be warm)
WARMUP_SWITCH = "HOPROVER_TEST_WARMUP"


def pytest_configure(config):
    """Compile once per test session, before pytest-xdist starts its workers: in the
    controller of an -n run (an xdist worker has `workerinput`), `python -m
    hoprover_env.compile` compiles (or loads) every kernel into numba's on-disk cache, so
    that the workers load them instead of each compiling the same kernels at once. A run
    without -n compiles what it uses on first use, as before. On a warm cache this only
    loads (seconds); if it fails, the tests run anyway and show the failure themselves."""
    if not hasattr(config, "workerinput") and config.getoption("numprocesses", None):
        # one OpenMP thread per xdist worker (torch's, and the train.py subprocesses'),
        # unless the caller chose: with a worker per core, torch's default of a thread per
        # core has each small op wait for a team on busy cores (measured: the training
        # and RL-library test files took 71 s with it, 60 s without, on 2 cores). numba
        # sizes its own pool (NUMBA_NUM_THREADS), so the thread tests are unaffected.
        os.environ.setdefault("OMP_NUM_THREADS", "1")
    if (
        hasattr(config, "workerinput")
        or not config.getoption("numprocesses", None)
        or config.getoption("collectonly")
        or os.environ.get(WARMUP_SWITCH, "1").strip() == "0"
    ):
        return
    start = time.monotonic()
    out = subprocess.run(
        [sys.executable, "-m", "hoprover_env.compile"], capture_output=True, text=True
    )
    if out.returncode == 0:  # its last line: what it compiled and loaded
        summary = (out.stdout.strip().splitlines() or [""])[-1]
        print(
            f"numba cache warmed for the workers in {time.monotonic() - start:.0f} s: {summary}",
            file=sys.stderr,
        )
    else:
        lines = (out.stdout + out.stderr).strip().splitlines()
        print(
            f"warning: `python -m hoprover_env.compile` failed (exit {out.returncode}); "
            "the workers compile on first use:\n" + "\n".join(lines[-15:]),
            file=sys.stderr,
        )


def pytest_collection_modifyitems(config, items):
    # pytest-xdist (the README's --dist loadfile --no-loadscope-reorder) hands out test
    # files in collection order: the long files (marked slow) go first, so that no worker
    # is left alone with one of them at the end while the other idles. Without
    # --no-loadscope-reorder xdist sorts the files by their number of tests instead,
    # which put these few-test, long files last.
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
