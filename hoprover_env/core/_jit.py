"""How every kernel function is compiled (numba options, signatures) and the guard
that keeps Python from calling the functions compiled for jitted callers only."""

from numba import njit, types as nt
from numba.core.registry import CPUDispatcher

# How every kernel function is compiled: cached on disk, numpy's error model (a division
# by zero gives inf/nan, which the callers check, instead of raising) and no reference
# counting (no function allocates). Functions only ever called from other jitted code get
# no Python and C entry wrappers (INNER): numba would otherwise build each one, optimise it
# and link it again into every caller, about 2 s of the cold start. The integrator's entry
# (advance, _advance_event) is inlined into its callers, so that the env's step does not
# pay for linking the whole kernel twice more (numba re-optimises every callee's code in
# each jitted caller). Calling an INNER function from Python raises a TypeError
# (guard_jit_only, at the end of each kernel module).
JIT = dict(cache=True, error_model="numpy", _nrt=False)
INNER = dict(JIT, no_cpython_wrapper=True, no_cfunc_wrapper=True)
JIT_INLINE = dict(JIT, inline="always")
INNER_INLINE = dict(INNER, inline="always")


class _JitOnlyDispatcher(CPUDispatcher):
    """An INNER function seen from Python. It has no Python entry: numba would jump to a
    null one and crash the interpreter (a segmentation fault), so the call raises."""

    def __call__(self, *args, **kwargs):
        f = self.py_func
        raise TypeError(f"{f.__module__}.{f.__qualname__} is compiled for calls from jitted "
                        "code only (core.INNER): call it from an @njit function, or compile "
                        "it with core.JIT to call it from Python")


def guard_jit_only(namespace: dict) -> None:
    """Make the INNER functions of a module raise TypeError when Python calls them.
    Called at the end of each kernel module; jitted callers are unaffected."""
    for obj in list(namespace.values()):
        if type(obj) is CPUDispatcher and obj.targetoptions.get("no_cpython_wrapper"):
            obj.__class__ = _JitOnlyDispatcher

# Declared signatures. Without one, numba compiles a separate copy of a function for every
# literal a caller passes (a corner 0 or 1, an event kind): Literal[int](0) is its own
# type. With one, the literals convert to the declared int64.
_V = nt.float64[::1]
_V32 = nt.float32[::1]
_M = nt.float64[:, ::1]
_F = nt.float64
_I = nt.int64
_B = nt.boolean
_F2 = nt.UniTuple(_F, 2)
_F4 = nt.UniTuple(_F, 4)
_F5 = nt.UniTuple(_F, 5)
_I2 = nt.UniTuple(_I, 2)


class _DeclaredSignature(CPUDispatcher):
    """A function with a declared signature, compiled when first used, not at import.

    `numba.njit(signature)` compiles at once: `import hoprover_env` compiled 37 functions
    (about 4 s) in source order before anything could run. Compiled on first use, import
    is cheap, a program compiles only what it uses, and on a cold cache the core can be
    compiled by two processes at once (hoprover_env._parallel_compile). First use is
    either a jitted caller being typed (get_call_template) or a call from Python. After
    compiling, the object becomes what `njit(signature)` would have made (compilation
    disabled; an INNER function guarded against Python calls)."""

    def compile_declared(self):
        self.compile(self.declared)
        self.disable_compile()
        jit_only = self.targetoptions.get("no_cpython_wrapper")
        self.__class__ = _JitOnlyDispatcher if jit_only else CPUDispatcher

    def get_call_template(self, args, kws):
        self.compile_declared()
        return self.get_call_template(args, kws)

    def __call__(self, *args, **kwargs):
        self.compile_declared()
        return self(*args, **kwargs)

    def __reduce__(self):       # pickled by reference (Ray, multiprocessing), as functions
        f = self.py_func
        return _module_attribute, (f.__module__, f.__qualname__)


def _module_attribute(module: str, name: str):
    import importlib
    return getattr(importlib.import_module(module), name)


def njit_declared(signature, **options):
    """`numba.njit(signature, **options)`, compiled on first use instead of at import."""
    def wrap(func):
        dispatcher = njit(**options)(func)
        dispatcher.__class__ = _DeclaredSignature
        dispatcher.declared = signature
        return dispatcher
    return wrap


def compile_declared(dispatcher) -> None:
    """Compile a declared-signature function now (nothing if it already is)."""
    if isinstance(dispatcher, _DeclaredSignature):
        dispatcher.compile_declared()
