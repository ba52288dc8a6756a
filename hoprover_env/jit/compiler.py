"""How every jitted function of hoprover is compiled: one decorator, `kernel`.

    @kernel                                  # callable from Python and from jitted code
    @kernel(inner=True)                      # called from jitted code only
    @kernel(F64(VEC, I64), inner=True)       # with a declared signature
    @kernel(parallel=True)                   # a prange loop

Every kernel is cached on disk (numba's ``cache=True``), uses numpy's error model (a
division by zero gives inf/nan, which callers check, instead of raising) and no
reference counting (nothing allocates). On top of plain numba it adds these, mostly
for the cold start (the first use after installing or editing), none of which changes
numba for anyone else in the process (docs/COMPILING.md):

* ``inner=True``: no Python/C entry wrappers. numba would otherwise build, optimise and
  link one per helper into every caller. Python calling such a function raises a
  TypeError instead of jumping to a missing entry (a crash).
* a declared signature compiles on first use, not at import (``numba.njit(signature)``
  compiles at once); it also stops numba from compiling a second copy for a literal
  argument (``corner = 0`` is its own type otherwise).
* stale caches are dropped: numba keys a cached function on its own file only, so a
  caller would keep an old callee's code linked in. One fingerprint over the kernel
  sources guards every module's cache.
* kernels built from templates (`bind`: a task's step and observation bound into the
  loops of tasks/common.py) carry in their names a digest of the source files of every
  function they embed, so that an edit to a task module, inside the package or outside
  it, compiles them afresh instead of loading the old code from numba's cache.
* `prepare()`: on a cold cache it prints one line (MESSAGE) and, with two or more cores,
  a helper process (a fresh interpreter, never a fork) and this one compile the
  simulator's parts into the cache, each taking the next part the other has not taken,
  like ``make -j2``. ``HOPROVER_PARALLEL_COMPILE=0`` turns the helper off.

`kernel` leans on numba internals (`_numba_internals`): the CPUDispatcher class, its
`get_call_template` hook, a dispatcher's `_cache` and the wrapper options. Should a numba
release move one of them, everything falls back to plain ``numba.njit(cache=True)`` with
a warning: correct results, a slower cold start (tests/core/test_compile.py hides them).
`run_threaded`, which restores the OpenMP settings numba's OpenMP layer changes, is in
jit/threads.py.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import importlib
import inspect
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import types
import warnings

from numba import njit
from numba import types as nt

F64, I64, BOOL, NONE = nt.float64, nt.int64, nt.boolean, nt.none
VEC, VEC32, MAT = nt.float64[::1], nt.float32[::1], nt.float64[:, ::1]
F64x2, F64x4, F64x5, I64x2 = (
    nt.UniTuple(F64, 2),
    nt.UniTuple(F64, 4),
    nt.UniTuple(F64, 5),
    nt.UniTuple(I64, 2),
)
OPTIONS = dict(cache=True, error_model="numpy", _nrt=False)

_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# the files whose code a cached kernel may embed (a change to any drops every cache): this
# layer's own, and those hoprover_env/_kernel_sources.py adds before any kernel is built
KERNEL_SOURCES = sorted(glob.glob(os.path.join(os.path.dirname(os.path.abspath(__file__)), "*.py")))


def add_kernel_sources(paths) -> None:
    """Add files to KERNEL_SOURCES: called by the package before its first kernel, since
    the fingerprint over them is taken when the first kernel is built."""
    if _fingerprint.cache_info().currsize:
        raise RuntimeError("kernel sources added after the first kernel was built")
    KERNEL_SOURCES[:] = sorted(set(KERNEL_SOURCES) | {os.path.abspath(p) for p in paths})


@functools.cache
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
        warnings.warn(
            f"hoprover_env: this numba ({exc} is missing) is not one hoprover's "
            "compile layer knows; falling back to plain numba.njit(cache=True): "
            "results are the same, the first run compiles more slowly",
            RuntimeWarning,
            stacklevel=3,
        )
        return None
    return CPUDispatcher


class _JitOnly:
    """Mixed into an inner function's dispatcher: Python may not call it."""

    __slots__ = ()

    def __call__(self, *args, **kwargs):
        f = self.py_func
        raise TypeError(
            f"{f.__module__}.{f.__qualname__} is compiled for calls from jitted "
            "code only (kernel(inner=True)): call it from a jitted function, or "
            "declare it without inner=True to call it from Python"
        )


class _Declared:
    """Mixed into a dispatcher with a declared signature: compiled when first used."""

    __slots__ = ()

    def compile_declared(self):
        self.compile(self.declared)
        self.disable_compile()
        self.__class__ = self.compiled_class

    def get_call_template(self, args, kws):  # a jitted caller is being typed
        self.compile_declared()
        return self.get_call_template(args, kws)

    def __call__(self, *args, **kwargs):
        self.compile_declared()
        return self(*args, **kwargs)

    def __reduce__(self):  # pickled by reference (Ray, multiprocessing), as functions
        f = self.py_func
        return _module_attribute, (f.__module__, f.__qualname__)


def _module_attribute(module: str, name: str):
    return getattr(importlib.import_module(module), name)


@functools.cache
def _subclass(*mixins):
    base = _numba_internals()
    return type("".join(m.__name__.strip("_") for m in mixins) + "Dispatcher", (*mixins, base), {})


def kernel(signature=None, *, inner: bool = False, inline: bool = False, parallel: bool = False):
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
        dispatcher.kernel_options = dict(
            signature=signature, inner=inner, inline=inline, parallel=parallel
        )
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
    new = types.FunctionType(func.__code__, {**func.__globals__, **names}, name, func.__defaults__)
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


def bind(func, name: str, options: dict | None = None, **names):
    """A kernel (``kernel(**options)``) built from the template `func` with some global
    names bound to other objects (`bind_globals`): a task's step template with its
    integrator, or the loops of tasks/common.py with a task's step and observation.

    numba keys a cached function on its own file and bytecode only, not on the code of
    what it calls, so a cached loop would keep an edited task module's old step linked
    in. The kernel is therefore called ``f"{name}_{digest}"``, `digest` being
    `source_digest` of the bound template: a hash of the source files of `func`, of the
    objects bound and of every kernel they reach. An edit to any of those files, inside
    the package or outside it, gives a new name, which numba compiles afresh; the
    cache files of the same kernel under other digests are deleted then."""
    digest = source_digest(bind_globals(func, name, **names))
    dispatcher = kernel(**(options or {}))(bind_globals(func, f"{name}_{digest}", **names))
    _drop_other_versions(dispatcher, name, digest)
    return dispatcher


DIGEST_LENGTH = 16  # hex digits of `source_digest`


def source_digest(*objects) -> str:
    """DIGEST_LENGTH hex digits of a hash over the source files (their paths and
    contents, each read once per process) of `objects` (functions or kernels) and of
    every kernel they reach through their global names, the attributes of modules they
    name, and their closures (`_source_files`)."""
    h = hashlib.sha256()
    for path in sorted(_source_files(objects)):
        h.update(path.encode("utf-8", "surrogateescape") + b"\0" + _file_hash(path))
    return h.hexdigest()[:DIGEST_LENGTH]


@functools.cache
def _file_hash(path: str) -> bytes:
    try:
        with open(path, "rb") as fh:
            return hashlib.sha256(fh.read()).digest()
    except OSError:  # no file (code made by exec): numba cannot cache it anyway
        return b"-"


def _is_kernel(obj) -> bool:
    return inspect.isfunction(getattr(obj, "py_func", None)) and hasattr(obj, "overloads")


def _code_names(code) -> set:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _code_names(const)
    return names


def _source_files(objects) -> set:
    """The files defining `objects` (functions or kernels) and every kernel reachable
    from them, and the files of the modules they are stored in: jitted code calls
    kernels only, named as globals (``f(x)``), as module attributes (``module.f(x)``)
    or held in a closure."""
    files, seen, todo = set(), set(), list(objects)
    while todo:
        func = todo.pop()
        func = getattr(func, "py_func", func)
        if not inspect.isfunction(func) or id(func) in seen:
            continue
        seen.add(id(func))
        files.add(func.__code__.co_filename)
        # and the module it is stored in, where that is another (a rebind of a callee)
        stored = getattr(sys.modules.get(func.__module__), "__file__", None)
        if stored:
            files.add(stored)
        names = _code_names(func.__code__)
        reached = []
        for name in names:
            value = func.__globals__.get(name)
            if isinstance(value, types.ModuleType):
                reached.extend(vars(value).get(attr) for attr in names)
            else:
                reached.append(value)
        for cell in func.__closure__ or ():
            try:
                reached.append(cell.cell_contents)
            except ValueError:  # an empty cell
                pass
        todo.extend(obj for obj in reached if _is_kernel(obj))
    return files


def _drop_other_versions(dispatcher, name: str, digest: str) -> None:
    """Delete the cache files of the kernels called ``f"{name}_{other digest}"`` of the
    dispatcher's module (`bind`): code for sources that are no more. Another process
    still running the old sources then recompiles what it finds missing."""
    path = _cache_path(dispatcher)
    if path is None:
        return
    stem = os.path.splitext(os.path.basename(dispatcher.py_func.__code__.co_filename))[0]
    pattern = re.compile(
        re.escape(f"{stem}.{name}_") + f"([0-9a-f]{{{DIGEST_LENGTH}}})-" + r".*\.nb[ic]$"
    )
    try:
        entries = os.listdir(path)
    except OSError:
        return
    for entry in entries:
        match = pattern.match(entry)
        if match and match.group(1) != digest:
            try:
                os.remove(os.path.join(path, entry))
            except OSError:
                pass


def compile_now(dispatcher) -> None:
    """Compile a declared-signature kernel now (nothing if it already is)."""
    if isinstance(dispatcher, _Declared):
        dispatcher.compile_declared()


def _cache_path(dispatcher):
    try:
        return dispatcher._cache.cache_path
    except AttributeError:
        return None


@functools.cache
def _fingerprint() -> str:
    h = hashlib.sha256()
    for path in KERNEL_SOURCES:
        with open(path, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()


@functools.cache
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
    except OSError:  # a read-only install: its cache was built for its sources
        pass


def drop_stale_cache(dispatcher) -> None:
    """Delete the cache files of the dispatcher's module if the kernel sources changed
    since they were written (checked once per module and process, before any load)."""
    path = _cache_path(dispatcher)
    if path is not None:
        stem = os.path.splitext(os.path.basename(dispatcher.py_func.__code__.co_filename))[0]
        _checked(path, stem)


# ---------------------------------------------------------------- the two-process compile
ENV_SWITCH = "HOPROVER_PARALLEL_COMPILE"  # "0": no helper
_HELPER_FLAG = "_HOPROVER_COMPILE_HELPER"  # set in the helper's environment
HELPER_TIMEOUT = 120.0  # s; a helper taking longer is killed
# The end of a phase (built for the ground), the largest piece (about 45 % of the work),
# is the main process's; then both processes take the next function not yet taken from
# QUEUE, then an env's extra functions, and last QUEUE_END: largest first, so that the two
# finish together (BENCHMARKS.md, "Cold start"). The kernels themselves are given by the
# layer that defines them (`register_warm`, called by core/smooth.py at import).
AFTER_PHASE: dict = {}  # {rough: kernel}
QUEUE: tuple = ()
QUEUE_END: tuple = ()
_prepared = False


def register_warm(after_phase: dict, queue, queue_end) -> None:
    """Name the kernels `prepare` compiles on a cold cache: the end of a phase per ground
    ({rough: kernel}), then QUEUE and QUEUE_END (see above)."""
    global AFTER_PHASE, QUEUE, QUEUE_END
    AFTER_PHASE, QUEUE, QUEUE_END = dict(after_phase), tuple(queue), tuple(queue_end)


def _reference(dispatcher) -> str:
    """The "module:name" of a kernel: how the helper finds it, as pickling one does."""
    f = dispatcher.py_func
    return f"{f.__module__}:{f.__qualname__}"


def _resolve(names):
    """The kernels `_reference` named (their modules are imported already in this
    process; in the helper, by importing hoprover_env, which imports every layer)."""
    return [_module_attribute(*name.split(":")) for name in names]


def _cached(dispatcher) -> bool:
    """Compiled in this process, or in numba's cache for the current source."""
    if dispatcher.overloads:
        return True
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 - caching off, or another numba layout:
        return True  # then a helper could not share its work; do not start it


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
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
        except OSError:  # a read-only cache directory, say
            return None
    return None


def prepare(extra=(), rough: bool = True) -> None:
    """Called by every entry point (envs, simulate, simulate_batch) before its first kernel
    call; returns at once after the first call in a process. `extra`: more declared
    functions ("module:name") to compile, such as an env's reward and observation;
    `rough`: False for a caller that starts on smooth ground (core/smooth.py).

    On a cold cache it prints the compile notice (MESSAGE) and, with two or more cores,
    compiles with a helper process (`_start_helper`)."""
    global _prepared
    if _prepared:
        return
    _prepared = True
    if os.environ.get(_HELPER_FLAG):
        return
    functions = QUEUE + QUEUE_END + tuple(extra)
    if all(_cached(d) for d in functions):
        return
    print(MESSAGE, file=sys.stderr, flush=True)
    if _numba_internals() is None or os.environ.get(ENV_SWITCH, "1").strip() == "0" or _cores() < 2:
        return
    lock = _claim(functions[0])
    if lock is None:
        return
    try:
        taken = tempfile.mkdtemp(prefix="hoprover-compile-")
    except OSError:  # no writable temporary directory: compile here alone
        taken = None
    try:
        if taken is None:
            return
        queue = (taken, *map(_reference, QUEUE + tuple(extra) + QUEUE_END))
        helper = _start_helper(queue)
        if helper is None:
            return
        started = time.monotonic()
        try:
            compile_now(AFTER_PHASE.get(bool(rough)))
            compile_queue(queue)
            helper.wait(timeout=max(0.0, started + HELPER_TIMEOUT - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass  # what the helper did not finish compiles here on first use
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
    """Compile each function of `queue` ("module:name" by `_reference`, after the
    directory where takers leave their marks) that no other process has taken: what both
    processes of `prepare` run."""
    taken, *names = queue
    for k, name in enumerate(names):
        try:
            os.close(os.open(os.path.join(taken, str(k)), os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            continue
        compile_now(_resolve((name,))[0])


def _start_helper(queue):
    """The helper process working through `queue` (`compile_queue`): a fresh interpreter,
    which shares nothing with this process but the cache directory and the directory of
    marks; None if it cannot start. Never a fork of this process: a fork is only safe
    where no other thread holds a lock the child needs, and hoprover cannot see threads
    that never run Python, such as numpy's BLAS pool (docs/COMPILING.md)."""
    # the helper must compile this very package, wherever it was imported from
    parent = os.path.dirname(_PACKAGE)
    path = os.pathsep.join(p for p in (parent, os.environ.get("PYTHONPATH")) if p)
    try:
        return subprocess.Popen(
            [
                sys.executable,
                "-c",
                "import sys, hoprover_env; from hoprover_env.jit import "
                "compiler as c; c.compile_queue(sys.argv[1:])",
                *queue,
            ],
            env=dict(os.environ, PYTHONPATH=path, **{_HELPER_FLAG: "1"}),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    except OSError:
        return None


# ---------------------------------------------------------------- the compile notice
MESSAGE = (
    "hoprover_env: compiling the simulator with numba, once after installing or "
    "editing it (usually 5-15 s; cached afterwards) ..."
)
