"""Keep numba's on-disk cache honest across modules.

numba keys a cached function on its own bytecode and its own file's time stamp. A cached
function in rl_kernel.py (or a benchmark driver) that calls the core has the core's
compiled code linked into it, so after the core changes it would keep running the old
physics. `drop_stale_cache(__file__)` fingerprints the kernel sources a module depends
on and deletes that module's cache files when the fingerprint changes; call it at the
top of such a module, before its first jitted function is compiled or loaded.
"""
from __future__ import annotations

import functools
import glob
import hashlib
import os

_HERE = os.path.dirname(os.path.abspath(__file__))
KERNEL_SOURCES = sorted(glob.glob(os.path.join(_HERE, "core", "*.py"))) + [
    os.path.join(_HERE, name) for name in ("params.py", "_dop853_tableau.py", "rl_kernel.py")]


def _probe():  # a function for numba's cache locators to look at
    pass


def _cache_dirs(py_file: str) -> list[str]:
    """Where numba may keep the cache of functions defined in py_file."""
    from numba.core import caching
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")
    dirs = []
    for cls in impl._locator_classes:
        try:
            loc = cls.from_function(_probe, py_file)
        except Exception:          # noqa: BLE001 - a locator that does not apply
            loc = None
        if loc is not None:
            dirs.append(loc.get_cache_path())
    return dirs


@functools.lru_cache(maxsize=None)
def _fingerprint(paths: tuple) -> str:
    h = hashlib.sha256()
    for path in paths:
        with open(path, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()


def fingerprint(paths=KERNEL_SOURCES) -> str:
    """One hash over the given source files (computed once per process: every kernel
    module asks at import)."""
    return _fingerprint(tuple(paths))


def drop_stale_cache(py_file: str, dependencies=KERNEL_SOURCES) -> None:
    """Delete py_file's numba cache files if the kernel sources changed since they were
    written (the module's own changes numba notices by itself)."""
    stem = os.path.splitext(os.path.basename(py_file))[0]
    deps = [d for d in dependencies if os.path.abspath(d) != os.path.abspath(py_file)]
    stamp = fingerprint(deps)
    for cache_dir in _cache_dirs(py_file):
        marker = os.path.join(cache_dir, f"{stem}.kernel-sources")
        try:
            with open(marker) as fh:
                if fh.read() == stamp:
                    continue
        except OSError:
            pass
        for path in glob.glob(os.path.join(cache_dir, f"{stem}.*.nb[ic]")):
            try:
                os.remove(path)
            except OSError:
                pass
        try:
            os.makedirs(cache_dir, exist_ok=True)
            with open(marker, "w") as fh:
                fh.write(stamp)
        except OSError:
            pass
