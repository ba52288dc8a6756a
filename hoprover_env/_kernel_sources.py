"""The package's source files whose code a cached kernel may embed, given to the compiler
(`jit.compiler.add_kernel_sources`) before any kernel is built: imported first by
hoprover_env/__init__.py, which runs before any layer. The compiler hashes them into the
fingerprint that guards every module's cache (docs/COMPILING.md, "How the cache is keyed");
it names no layer above its own."""

import glob
import os

from hoprover_env.jit.compiler import add_kernel_sources

_HERE = os.path.dirname(os.path.abspath(__file__))
add_kernel_sources(
    glob.glob(os.path.join(_HERE, "core", "*.py"))
    + glob.glob(os.path.join(_HERE, "tasks", "*.py"))
    + [os.path.join(_HERE, "sim", name) for name in ("controllers.py", "control_loop.py")]
)
