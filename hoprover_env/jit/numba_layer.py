"""What hoprover can change in numba's compiler, for the cold start: link-only libraries,
a cheaper comparison of compiler flags, and three of numba's Python-side costs cut
without changing what it computes. `install()` applies them all.

**Opt-in: ``HOPROVER_NUMBA_LAYER=1``.** By default hoprover leaves numba as it is and
this module is not imported. With the switch on, `install()` (called when the first
kernel is declared) replaces methods of numba's ``JITCodeLibrary``, ``JITCPUCodegen``,
``TargetConfig`` (the compiler flags), ``ir.Inst`` and its error colour scheme, and drops
numba's callbacks around llvmlite's lock, for the whole process and for good: the
user's own numba code compiles through them too, and they rest on numba internals that
a numba release may move or change in meaning (a move is caught: `install` then changes
nothing and warns; a change in meaning is not). What it saves and costs is measured in
docs/COMPILING.md.

**Link-only libraries.** numba finalises the library of every function it compiles at
once: the function's LLVM module, with every callee's module linked in, goes through the
full module optimiser and becomes machine code, and that object code is what the on-disk
cache stores. A function
only jitted code calls (`kernel(inner=True)`: no Python entry, no cfunc) never runs on
its own. Its callers link its LLVM module (numba keeps a copy for linking) and optimise
and emit it again as part of their own. So the optimisation and the machine code of each
inner library, each of which repeats its whole call tree, are thrown away. On a cold
first `HopRover-v0` step that was 2.2 s of machine code and 1.5 s of module optimisation
out of 12.4 CPU s (timed per library, one process, 2026-11-25).

`install()` changes numba's JIT code library so that a freshly compiled library:

* is optimised by the module optimiser only if it defines an entry point (a ``cpython.``
  wrapper or a ``cfunc.``); an inner library keeps numba's per-function simplification
  and is optimised, with everything else, inside the caller that links it;
* joins the execution engine (machine code) only when something asks for the address
  of a symbol it defines, which for an inner function nothing ever does;
* is cached, if it never joined the engine, as its linkable bitcode under the
  serialisation kind ``"linkonly"`` instead of object code, and loads back as such.

Libraries loaded from a cache as object code are untouched. Results are bit for bit
the same (tests/test_regressions.py and the terrain tests compare trajectories): the code
that runs is the top-level library's, optimised from the same IR, and LLVM's optimiser
does not change floating-point results without fast-math flags, which hoprover never
sets. Step speed was compared in alternating runs (BENCHMARKS.md, "Cold start").

**Flags compared by what they hold.** numba keys its cache of overload implementations
on the compiler flags in force (a ``TargetConfig``); hashing one built a dict of its
~40 options and sorted it, and comparing two built two. Typing hoprover's kernels does
this about 200 000 times: 1.0 of 10.6 CPU s of a cold first step (alternating runs,
2026-11-25). Here the hash is computed once per flags class (numba's hash depends on the
option names only) and two flags of one class are compared on the options either has
set, the others holding their defaults in both; flags of two classes are compared as
numba does.

**Three Python-side costs.** The first two together took about 5 % of a cold first
step in one process (9.9 s against 10.5 s, medians of 8 alternating runs, 2026-11-26;
the third, measured only with the others, matters only where colorama is installed),
each with the same result as numba's own:

* numba broadcasts an event at every acquire and release of its LLVM lock, around
  every one of the ~40 000 calls into LLVM of a cold first step, to as many listeners
  as compilations are nested, only to fill each compile result's diagnostic timer
  ``metadata["timers"]["llvm_lock"]``. The lock is kept; the events are dropped (that
  timer reads 0).
* ``ir.Inst._rec_list_vars``, which lists the variables of an IR statement for numba's
  analyses (285 000 calls), tests every value it meets against four classes in turn;
  here each value's type is classified once, and the variables come out in numba's
  order.
* every error message numba builds while typing, most for overloads it tries and
  drops (18 000), wrapped and unwrapped the standard streams with colorama to mark it
  up; the same string is now built without touching the streams.

This leans on numba internals (``JITCodeLibrary``, ``JITCPUCodegen.set_env``,
``TargetConfig``, ``ir.Inst._rec_list_vars``, llvmlite's lock callbacks), as the rest of
`compiler`: if any is missing, `install` raises AttributeError before changing anything,
and `compiler` warns and compiles with numba as it is.
"""
from __future__ import annotations

_ENTRY_PREFIXES = ("_ZN7cpython", "cfunc.")
_LIBRARY_METHODS = ("finalize", "_finalize_final_module", "_optimize_final_module",
                    "get_pointer_to_function", "serialize_using_object_code", "_unserialize",
                    "_get_module_for_linking", "_finalize_dynamic_globals",
                    "_verify_declare_only_symbols", "_ensure_finalized")


def install() -> None:
    """The changes of the module docstring (idempotent)."""
    from llvmlite.binding import ffi
    from numba.core import codegen as cg, ir, targetconfig as tc
    lib, gen = cg.JITCodeLibrary, cg.JITCPUCodegen
    if getattr(lib, "_hoprover_link_only", False):
        return
    for name in _LIBRARY_METHODS:
        if not hasattr(lib, name):
            raise AttributeError(f"JITCodeLibrary.{name}")
    for cls, name in ((gen, "set_env"), (tc.TargetConfig, "options"),
                      (tc.TargetConfig, "values"), (ir.Inst, "_rec_list_vars")):
        if not hasattr(cls, name):
            raise AttributeError(f"{cls.__name__}.{name}")
    if not isinstance(getattr(getattr(ffi.lib, "_lock", None), "_cblist", None), list):
        raise AttributeError("llvmlite.binding.ffi.lib._lock._cblist")
    _compare_flags_cheaply(tc.TargetConfig)
    _link_only_libraries(lib, gen)
    _no_llvm_lock_events(ffi.lib._lock._cblist)
    _list_vars_by_type(ir)
    _plain_error_markup()


def _no_llvm_lock_events(callbacks: list) -> None:
    # numba's pair (numba.core.base._initialize_llvm_lock_event); any other stays
    callbacks[:] = [pair for pair in callbacks
                    if getattr(pair[0], "__module__", None) != "numba.core.base"]


def _list_vars_by_type(ir) -> None:
    VAR, INST, SEQ, MAP, LEAF = range(1, 6)           # all true: kinds.get(t) or ...
    kinds = {}

    def kind(t):
        kinds[t] = (VAR if issubclass(t, ir.Var) else INST if issubclass(t, ir.Inst)
                    else SEQ if issubclass(t, (list, tuple))
                    else MAP if issubclass(t, dict) else LEAF)      # numba's order of tests
        return kinds[t]

    def collect(values, out):       # depth first, as numba's recursion
        for v in values:
            k = kinds.get(type(v)) or kind(type(v))
            if k == VAR:
                out.append(v)
            elif k == INST:
                out.extend(v.list_vars())
            elif k == SEQ:
                collect(v, out)
            elif k == MAP:
                collect(v.values(), out)

    def _rec_list_vars(self, val):
        k = kinds.get(type(val)) or kind(type(val))
        if k == VAR:
            return [val]
        if k == INST:
            return val.list_vars()
        out = []
        if k != LEAF:
            collect(val if k == SEQ else val.values(), out)
        return out

    _rec_list_vars.numba_version = ir.Inst._rec_list_vars
    ir.Inst._rec_list_vars = _rec_list_vars


def _plain_error_markup() -> None:
    from numba.core import errors
    scheme = getattr(errors, "HighlightColorScheme", None)
    if scheme is None or not hasattr(errors, "Style"):      # numba without colorama
        return
    reset = errors.Style.RESET_ALL

    def _markup(self, msg, color=None, style=errors.Style.BRIGHT):
        return (color or "") + (style or "") + msg + reset

    _markup.numba_version = scheme._markup
    scheme._markup = _markup


def _compare_flags_cheaply(config) -> None:
    hashes = {}

    def __hash__(self):
        cls = type(self)
        if cls not in hashes:
            hashes[cls] = hash(tuple(sorted(self.options)))    # numba's: the names only
        return hashes[cls]

    def __eq__(self, other):
        if type(self) is type(other):
            # numba's test (values() == values()) on the options either has set: an
            # option neither has set holds its default in both
            mine, theirs = self._values, other._values
            if mine == theirs:
                return True
            options = self.options
            return all(mine.get(k, options[k].default) == theirs.get(k, options[k].default)
                       for k in mine.keys() | theirs.keys())
        if isinstance(other, config):
            return self.values() == other.values()
        return NotImplemented

    config.__hash__ = __hash__
    config.__eq__ = __eq__


def _link_only_libraries(lib, gen) -> None:
    from llvmlite import binding as ll

    finalize, finalize_module = lib.finalize, lib._finalize_final_module
    optimize, pointer = lib._optimize_final_module, lib.get_pointer_to_function
    serialize, unserialize = lib.serialize_using_object_code, lib._unserialize.__func__
    set_env = gen.set_env

    def has_entry(library) -> bool:
        return any(f.name.startswith(_ENTRY_PREFIXES) and not f.is_declaration
                   for f in library._final_module.functions)

    def join_engine(library) -> None:
        """Optimise (if skipped) and emit the library's machine code now; then set the
        environments its module defines, which set_env could not set before."""
        library._hoprover_pending = False
        if getattr(library, "_hoprover_unoptimized", False):
            library._hoprover_unoptimized = False
            optimize(library)
        finalize_module(library)
        waiting = library._codegen.__dict__.get("_hoprover_envs")
        if waiting:
            for gv in library._final_module.global_variables:
                if gv.name in waiting:            # kept: another library may link it
                    set_env(library._codegen, gv.name, waiting[gv.name])

    def new_finalize(self):
        self._hoprover_fresh = True             # compiled here, not loaded from a cache
        try:
            finalize(self)
        finally:
            self._hoprover_fresh = False

    def new_optimize(self):
        if getattr(self, "_hoprover_fresh", False) and not has_entry(self):
            self._hoprover_unoptimized = True   # its callers optimise it with themselves
            return
        optimize(self)

    def new_finalize_module(self):
        if not getattr(self, "_hoprover_fresh", False):
            return finalize_module(self)
        self._finalize_dynamic_globals()        # the cache checks these
        self._verify_declare_only_symbols()
        self._finalized = True
        self._hoprover_pending = True

    def new_pointer(self, name):
        self._ensure_finalized()
        if getattr(self, "_hoprover_pending", False):
            try:
                ours = not self._final_module.get_function(name).is_declaration
            except NameError:
                ours = False
            if not ours:                        # an inner function's missing wrapper
                engine = self._codegen._engine
                return engine.get_function_address(name) \
                    if engine.is_symbol_defined(name) else 0
            join_engine(self)
        return pointer(self, name)

    def new_serialize(self):
        self._ensure_finalized()
        if getattr(self, "_hoprover_pending", False):
            return (self.name, "linkonly", self._get_module_for_linking().as_bitcode())
        return serialize(self)

    def new_unserialize(cls, codegen, state):
        name, kind, data = state
        if kind != "linkonly":
            return unserialize(cls, codegen, state)
        self = codegen.create_library(name)
        self._final_module = self._shared_module = ll.parse_bitcode(data)
        self._finalize_dynamic_globals()
        self._finalized = True
        self._hoprover_pending = True
        return self

    def new_set_env(self, env_name, env):
        # the environment of a library not in the engine: set when (if) it joins
        if not self._engine.is_symbol_defined(env_name):
            self.__dict__.setdefault("_hoprover_envs", {})[env_name] = env
            return
        set_env(self, env_name, env)

    lib.finalize = new_finalize
    lib._optimize_final_module = new_optimize
    lib._finalize_final_module = new_finalize_module
    lib.get_pointer_to_function = new_pointer
    lib.serialize_using_object_code = new_serialize
    lib._unserialize = classmethod(new_unserialize)
    gen.set_env = new_set_env
    lib._hoprover_link_only = True
