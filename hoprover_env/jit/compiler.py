"""How every jitted function of hoprover is compiled: one decorator, `kernel`.

    @kernel                                  # callable from Python and from jitted code
    @kernel(inner=True)                      # called from jitted code only
    @kernel(F64(VEC, I64), inner=True)       # with a declared signature
    @kernel(parallel=True)                   # a prange loop

Every kernel is cached on disk (numba's ``cache=True``), uses numpy's error model (a
division by zero gives inf/nan, which callers check, instead of raising) and no
reference counting (nothing allocates). On top of plain numba it adds five things, each
for the cold start (the first use after installing or editing):

* ``inner=True``: no Python/C entry wrappers. numba would otherwise build, optimise and
  link one per helper into every caller. Python calling such a function raises a
  TypeError instead of jumping to a missing entry (a crash).
* a declared signature compiles on first use, not at import (``numba.njit(signature)``
  compiles at once); it also stops numba from compiling a second copy for a literal
  argument (``corner = 0`` is its own type otherwise).
* stale caches are dropped: numba keys a cached function on its own file only, so a
  caller would keep an old callee's code linked in. One fingerprint over the kernel
  sources guards every module's cache.
* changes to numba's compiler (`_numba_layer`): a function only jitted code calls is
  neither optimised as a module nor turned into machine code on its own, since its
  callers optimise and emit it with themselves (the cache keeps its linkable bitcode);
  compiler flags are hashed and compared without rebuilding their option dicts; no
  events around numba's LLVM lock, IR variables listed by type, error messages marked
  up without colorama. ``HOPROVER_NUMBA_LAYER=0`` leaves numba as it is.
* `prepare()`: on a cold cache with two or more cores, a helper process (a fork of this
  one on Linux) and this one compile the simulator's parts into the cache, each taking
  the next part the other has not taken, like ``make -j2``.
  ``HOPROVER_PARALLEL_COMPILE=0`` turns it off.

These lean on numba internals (`_numba_internals`): the CPUDispatcher class, its
`get_call_template` hook, a dispatcher's `_cache`, the wrapper options, the JIT code
library and the flags class (`_numba_layer`). Should a numba release move one of the
first four, everything falls back to plain ``numba.njit(cache=True)`` with a warning:
correct results, a slower cold start (tests/test_compile.py hides them); should it move
one of the last two, only `_numba_layer` is left out, with a warning.
"""
from __future__ import annotations

import functools
import glob
import hashlib
import importlib
import inspect
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import types
import warnings

from numba import njit, types as nt
from numba.core import event

F64, I64, BOOL, NONE = nt.float64, nt.int64, nt.boolean, nt.none
VEC, VEC32, MAT = nt.float64[::1], nt.float32[::1], nt.float64[:, ::1]
F64x2, F64x4, F64x5, I64x2 = (nt.UniTuple(F64, 2), nt.UniTuple(F64, 4),
                              nt.UniTuple(F64, 5), nt.UniTuple(I64, 2))
OPTIONS = dict(cache=True, error_model="numpy", _nrt=False)

_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# the files whose code a cached kernel may embed (a change to any drops every cache)
KERNEL_SOURCES = sorted(glob.glob(os.path.join(_PACKAGE, "core", "*.py"))
                        + glob.glob(os.path.join(_PACKAGE, "tasks", "*.py"))
                        + glob.glob(os.path.join(_PACKAGE, "jit", "*.py"))
                        + [os.path.join(_PACKAGE, "sim", name) for name in (
                            "controllers.py", "rollout.py")])


LAYER_SWITCH = "HOPROVER_NUMBA_LAYER"        # "0": numba as it is (_numba_layer)


@functools.lru_cache(maxsize=None)
def _numba_internals():
    """The numba internals used here, or None (with one warning) if any has moved."""
    try:
        from numba.core.registry import CPUDispatcher
        for name in ("get_call_template", "compile", "disable_compile"):
            if not hasattr(CPUDispatcher, name):
                raise AttributeError(f"CPUDispatcher.{name}")
        from numba.core.caching import FunctionCache
        if not hasattr(FunctionCache, "cache_path"):
            raise AttributeError("FunctionCache.cache_path")
    except (ImportError, AttributeError) as exc:
        warnings.warn(f"hoprover_env: this numba ({exc} is missing) is not one hoprover's "
                      "compile layer knows; falling back to plain numba.njit(cache=True): "
                      "results are the same, the first run compiles more slowly",
                      RuntimeWarning, stacklevel=3)
        return None
    if os.environ.get(LAYER_SWITCH, "1") != "0":
        try:
            from hoprover_env.jit import numba_layer as _numba_layer
            _numba_layer.install()
        except AttributeError as exc:
            warnings.warn(f"hoprover_env: this numba ({exc} is missing) is not one "
                          "hoprover's changes to numba's compiler know (_numba_layer); "
                          "compiling without them: the same results, a slower first run",
                          RuntimeWarning, stacklevel=3)
    return CPUDispatcher


class _JitOnly:
    """Mixed into an inner function's dispatcher: Python may not call it."""

    __slots__ = ()

    def __call__(self, *args, **kwargs):
        f = self.py_func
        raise TypeError(f"{f.__module__}.{f.__qualname__} is compiled for calls from jitted "
                        "code only (kernel(inner=True)): call it from a jitted function, or "
                        "declare it without inner=True to call it from Python")


class _Declared:
    """Mixed into a dispatcher with a declared signature: compiled when first used."""

    __slots__ = ()

    def compile_declared(self):
        self.compile(self.declared)
        self.disable_compile()
        self.__class__ = self.compiled_class

    def get_call_template(self, args, kws):       # a jitted caller is being typed
        self.compile_declared()
        return self.get_call_template(args, kws)

    def __call__(self, *args, **kwargs):
        self.compile_declared()
        return self(*args, **kwargs)

    def __reduce__(self):       # pickled by reference (Ray, multiprocessing), as functions
        f = self.py_func
        return _module_attribute, (f.__module__, f.__qualname__)


def _module_attribute(module: str, name: str):
    return getattr(importlib.import_module(module), name)


@functools.lru_cache(maxsize=None)
def _subclass(*mixins):
    base = _numba_internals()
    return type("".join(m.__name__.strip("_") for m in mixins) + "Dispatcher",
                (*mixins, base), {})


def kernel(signature=None, *, inner: bool = False, inline: bool = False,
           parallel: bool = False):
    """Compile a function with numba (see the module docstring); usable bare."""
    if inspect.isfunction(signature):
        return kernel()(signature)

    def wrap(func):
        plain = _numba_internals() is None
        options = dict(OPTIONS, parallel=parallel)
        if inline:
            options["inline"] = "always"
        if inner and not plain:
            options.update(no_cpython_wrapper=True, no_cfunc_wrapper=True)
        dispatcher = njit(**options)(func)
        drop_stale_cache(dispatcher)
        # what rebind() needs to compile a copy the same way
        dispatcher.kernel_options = dict(signature=signature, inner=inner, inline=inline,
                                         parallel=parallel)
        if plain:
            return dispatcher
        if signature is not None:
            dispatcher.__class__ = _subclass(_Declared)
            dispatcher.declared = signature
            dispatcher.compiled_class = _subclass(_JitOnly) if inner else _numba_internals()
        elif inner:
            dispatcher.__class__ = _subclass(_JitOnly)
        return dispatcher
    return wrap


def bind_globals(func, name: str, module: str | None = None, **names):
    """`func` with some global names bound to other objects, as a new function called
    `name` (of `module`, if given: where it can be found by name, as pickling a kernel
    by reference does). numba resolves globals when it compiles and caches a function
    under its qualified name, so each binding is compiled and cached on its own."""
    new = types.FunctionType(func.__code__, {**func.__globals__, **names}, name,
                             func.__defaults__)
    new.__qualname__ = name
    new.__doc__ = func.__doc__
    new.__module__ = module or func.__module__
    return new


def rebind(dispatcher, name: str, module: str, inner: bool | None = None, **names):
    """A kernel compiled as `dispatcher` was (signature, inner, ...), from its source
    with some globals bound to other objects (`bind_globals`): a callee swapped for a
    variant, or a constant that numba prunes branches on. It must be stored as `name`
    in `module` (a kernel is pickled by reference). `inner` overrides."""
    options = dict(dispatcher.kernel_options)
    if inner is not None:
        options["inner"] = inner
    return kernel(**options)(bind_globals(dispatcher.py_func, name, module, **names))


def compile_now(dispatcher) -> None:
    """Compile a declared-signature kernel now (nothing if it already is)."""
    if isinstance(dispatcher, _Declared):
        dispatcher.compile_declared()


def _layer_active() -> bool:
    from numba.core import codegen
    return bool(getattr(codegen.JITCodeLibrary, "_hoprover_link_only", False))


def _cache_path(dispatcher):
    try:
        return dispatcher._cache.cache_path
    except AttributeError:
        return None


@functools.lru_cache(maxsize=None)
def _fingerprint() -> str:
    h = hashlib.sha256()
    # a cache of link-only libraries is unreadable without them, and the reverse
    h.update(b"link-only" if _layer_active() else b"numba")
    for path in KERNEL_SOURCES:
        with open(path, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()


@functools.lru_cache(maxsize=None)
def _checked(cache_dir: str, stem: str) -> None:
    marker = os.path.join(cache_dir, f"{stem}.kernel-sources")
    try:
        with open(marker) as fh:
            if fh.read() == _fingerprint():
                return
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
            fh.write(_fingerprint())
    except OSError:             # a read-only install: its cache was built for its sources
        pass


def drop_stale_cache(dispatcher) -> None:
    """Delete the cache files of the dispatcher's module if the kernel sources changed
    since they were written (checked once per module and process, before any load)."""
    path = _cache_path(dispatcher)
    if path is not None:
        stem = os.path.splitext(os.path.basename(dispatcher.py_func.__code__.co_filename))[0]
        _checked(path, stem)


# ---------------------------------------------------------------- the two-process compile
ENV_SWITCH = "HOPROVER_PARALLEL_COMPILE"     # "0": no helper; "spawn": not a fork
_HELPER_FLAG = "_HOPROVER_COMPILE_HELPER"     # set in the helper's environment
HELPER_TIMEOUT = 120.0                        # s; a helper taking longer is killed
# The end of a phase (built for the ground, core/smooth.py), the largest piece (about
# 45 % of the work), is the main process's; then both processes take the next function
# not yet taken from QUEUE, then an env's extra functions, and last QUEUE_END: largest
# first, so that the two finish together (BENCHMARKS.md, "Cold start").
AFTER_PHASE = {True: "hoprover_env.core.phase_end:after_phase",
               False: "hoprover_env.core.smooth:after_phase_smooth"}
QUEUE = ("hoprover_env.core.contact_phases:contact_phase",
         "hoprover_env.core.flight:flight_phase")
QUEUE_END = ("hoprover_env.core.integrator:init_state",
             "hoprover_env.core.contact_phases:g_phase")
HELPER_FUNCTIONS = QUEUE + QUEUE_END          # what prepare() looks for in the cache
_prepared = False


def _resolve(names):
    return [_module_attribute(*name.split(":")) for name in names]


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
    path = _cache_path(dispatcher)
    if path is None:
        return None
    path = os.path.join(path, "hoprover-compile-helper.lock")
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


def prepare(extra=(), rough: bool = True) -> None:
    """Called by every entry point (envs, simulate, simulate_batch) before its first kernel
    call; returns at once after the first call in a process. `extra`: more declared
    functions ("module:name") to compile, such as an env's reward and observation;
    `rough`: False for a caller that starts on smooth ground (core/smooth.py)."""
    global _prepared
    if _prepared:
        return
    _prepared = True
    if _numba_internals() is None or os.environ.get(_HELPER_FLAG) \
            or os.environ.get(ENV_SWITCH, "1") == "0" or _cores() < 2:
        return
    functions = _resolve(HELPER_FUNCTIONS + tuple(extra))
    if all(_cached(d) for d in functions):
        return
    lock = _claim(functions[0])
    if lock is None:
        return
    try:
        taken = tempfile.mkdtemp(prefix="hoprover-compile-")
    except OSError:             # no writable temporary directory: compile here alone
        taken = None
    try:
        if taken is None:
            return
        queue = (taken,) + QUEUE + tuple(extra) + QUEUE_END
        fork = os.environ.get(ENV_SWITCH) != "spawn" and _can_fork()
        helper = _start_helper(queue, fork)
        if helper is None:
            return
        started = time.monotonic()
        try:
            compile_now(_resolve((AFTER_PHASE[bool(rough)],))[0])
            compile_queue(queue)
            helper.wait(timeout=max(0.0, started + HELPER_TIMEOUT - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass                # what the helper did not finish compiles here on first use
        finally:
            if helper.poll() is None:
                helper.kill()
                helper.wait()
    finally:
        if taken is not None:
            shutil.rmtree(taken, ignore_errors=True)
        try:
            os.remove(lock)
        except OSError:
            pass


def compile_queue(queue) -> None:
    """Compile each function of `queue` ("module:name", after the directory where
    takers leave their marks) that no other process has taken: what both processes of
    `prepare` run."""
    taken, *names = queue
    for k, name in enumerate(names):
        try:
            os.close(os.open(os.path.join(taken, str(k)), os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            continue
        compile_now(_resolve((name,))[0])


def _start_helper(queue, fork: bool):
    """The helper process working through `queue` (`compile_queue`); None if it cannot
    start. `fork`: a fork of this process, which spares the helper the start of a new
    interpreter and its imports (about 0.4 s); else a fresh interpreter
    (``HOPROVER_PARALLEL_COMPILE=spawn`` asks for one where a fork would do)."""
    if fork:
        try:
            return _Forked(queue)
        except OSError:
            return None
    # the helper must compile this very package, wherever it was imported from
    parent = os.path.dirname(_PACKAGE)
    path = os.pathsep.join(p for p in (parent, os.environ.get("PYTHONPATH")) if p)
    try:
        return subprocess.Popen(
            [sys.executable, "-c", "import sys; from hoprover_env.jit import compiler as c; "
             "c.compile_queue(sys.argv[1:])", *queue],
            env=dict(os.environ, PYTHONPATH=path, **{_HELPER_FLAG: "1"}),
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except OSError:
        return None


def _can_fork() -> bool:
    """Linux, and no Python thread but this one: a thread of ours (Jupyter's, a Ray
    worker's) could hold a lock at the moment of the fork that the child would then
    wait on for ever. Threads that never run Python (a BLAS pool) hold nothing the child
    uses: it only compiles."""
    return sys.platform.startswith("linux") and threading.active_count() == 1


class _Forked:
    """The helper as a fork of this process, with the part of `subprocess.Popen`'s
    interface `prepare` uses (poll, wait, kill).

    It forks under numba's compiler lock, so that no other thread is halfway through a
    compilation whose state the child would inherit. The child works through its queue
    into numba's cache with its standard streams on /dev/null and leaves by `os._exit`: no
    atexit handlers, no flushing of the buffers it shares with this process."""

    def __init__(self, queue):
        from numba.core.compiler_lock import global_compiler_lock
        self.returncode = None
        with warnings.catch_warnings():
            # Python 3.12+ warns of a fork in a process with threads (a BLAS pool's);
            # _can_fork said why the child is safe from them
            warnings.simplefilter("ignore", DeprecationWarning)
            with global_compiler_lock:
                self.pid = os.fork()
                if self.pid == 0:
                    self._child(queue)

    @staticmethod
    def _child(queue):
        code = 1
        try:
            null = os.open(os.devnull, os.O_RDWR)
            for fd in (0, 1, 2):
                os.dup2(null, fd)
            compile_queue(queue)
            code = 0
        finally:
            os._exit(code)

    def poll(self):
        if self.returncode is None:
            try:
                pid, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:       # reaped elsewhere (SIGCHLD ignored): gone
                self.returncode = -1
                return self.returncode
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout=None):
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() >= deadline:
                raise subprocess.TimeoutExpired("hoprover compile helper", timeout)
            time.sleep(0.002)
        return self.returncode

    def kill(self):
        try:
            os.kill(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


# ---------------------------------------------------------------- the compile notice
MESSAGE = ("hoprover_env: compiling the simulator with numba, once after installing or "
           "editing it (usually 5-15 s; cached afterwards) ...")


@functools.cache
def _openmp():
    """The OpenMP runtime numba's default threading layer runs on: libgomp by its soname,
    which resolves to the copy already loaded if there is one (with torch imported,
    numba's layer and torch were seen to share it). None where there is none."""
    import ctypes
    try:
        lib = ctypes.CDLL("libgomp.so.1")
        lib.omp_get_max_threads.restype = ctypes.c_int
        lib.omp_set_num_threads.argtypes = [ctypes.c_int]
        return lib
    except (OSError, AttributeError):
        return None


def run_threaded(fn, *args):
    """`fn(*args)` for a parallel kernel, leaving the caller's OpenMP thread count as it
    was. numba's OpenMP layer sets it to numba's thread count in the calling thread at
    every launch, and every later OpenMP user in the process inherits that: after one
    threaded step, torch.set_num_threads(1) reads 2 and torch's small ops run on two
    threads that spin against the env's (PPO's updates 5x slower here, on 2 cores)."""
    lib = _openmp()
    if lib is None:
        return fn(*args)
    n = lib.omp_get_max_threads()
    try:
        return fn(*args)
    finally:
        if lib.omp_get_max_threads() != n:
            lib.omp_set_num_threads(n)


class _CompileNotice(event.Listener):
    """One line on stderr when numba starts compiling one of this package's kernels
    (cached runs compile nothing and print nothing)."""

    shown = False

    def on_start(self, ev):
        if self.shown:
            return
        data = ev.data if isinstance(ev.data, dict) else {}
        func = getattr(data.get("dispatcher"), "py_func", None)
        if (getattr(func, "__module__", None) or "").startswith("hoprover_env."):
            type(self).shown = True
            print(MESSAGE, file=sys.stderr, flush=True)

    def on_end(self, ev):
        pass


event.register("numba:compile", _CompileNotice())
