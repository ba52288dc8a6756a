"""Running hoprover's parallel kernels: `run_threaded`, which restores the OpenMP
settings numba's OpenMP layer changes in the calling thread (docs/COMPILING.md, "Threads:
`run_threaded`"). Every threaded launch (the threaded vector env, `simulate_batch`) goes
through it; it loads nothing and never calls numba.set_num_threads."""

from __future__ import annotations

import os
import threading

_OPENMP = []  # [runtime or None], once known (_openmp)


def _openmp():
    """The OpenMP runtime numba's OpenMP layer runs on, if one is loaded: libgomp by its
    soname, which is the copy already loaded (torch's, if torch came first: numba's and
    torch's were seen to share it). Loads nothing (RTLD_NOLOAD). Known for good once one
    is loaded, or once numba's threads have started without one (its TBB or workqueue
    layer); until then None, looked up again at the next call."""
    if _OPENMP:
        return _OPENMP[0]
    import ctypes

    try:
        lib = ctypes.CDLL("libgomp.so.1", mode=getattr(os, "RTLD_NOLOAD", 4))
        for name in ("omp_get_max_threads", "omp_get_max_active_levels"):
            getattr(lib, name).restype = ctypes.c_int
        for name in ("omp_set_num_threads", "omp_set_max_active_levels"):
            getattr(lib, name).argtypes = [ctypes.c_int]
    except (OSError, AttributeError):
        try:
            from numba.np.ufunc import parallel

            if parallel._is_initialized:  # numba's threads run without OpenMP
                _OPENMP.append(None)
        except (ImportError, AttributeError):
            pass
        return None
    _OPENMP.append(lib)
    return lib


def _openmp_settings(lib):
    return lib.omp_get_max_threads(), lib.omp_get_max_active_levels()


def _default_threads(lib) -> int:
    """The OpenMP thread count a thread that never set one reads: the runtime's default."""
    out = []
    thread = threading.Thread(target=lambda: out.append(lib.omp_get_max_threads()))
    thread.start()
    thread.join()
    return out[0]


def run_threaded(fn, *args):
    """`fn(*args)` for a parallel kernel, leaving the caller's OpenMP settings as they
    were. numba's OpenMP layer sets the calling thread's OpenMP thread count to numba's
    thread count when it starts and at every launch, and the runtime's nesting level
    when it starts; every later OpenMP user in the process inherits that: after one
    threaded step, torch.set_num_threads(1) read 2 and torch's small ops ran on two
    threads that spun against the env's. numba's own thread count
    (numba.set_num_threads) is neither read nor changed."""
    lib = _openmp()
    before = _openmp_settings(lib) if lib is not None else None
    try:
        return fn(*args)
    finally:
        if lib is None and not _OPENMP:
            lib = _openmp()
            if lib is not None:  # loaded by this call (numba's threads started)
                before = (_default_threads(lib), lib.omp_get_max_active_levels())
        if lib is not None:
            now = _openmp_settings(lib)
            if now[0] != before[0]:
                lib.omp_set_num_threads(before[0])
            if now[1] != before[1]:
                lib.omp_set_max_active_levels(before[1])
