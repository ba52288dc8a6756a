"""One line on stderr when numba starts compiling the simulator.

The first use after installing (or editing) hoprover_env compiles the kernel, which
takes seconds with no output otherwise. Cached runs load the compiled code and print
nothing: numba reports a "numba:compile" event only on a real compilation.
"""
from __future__ import annotations

import sys

from numba.core import event

MESSAGE = ("hoprover_env: compiling the simulator with numba, once after installing or "
           "editing it (usually 5-15 s; cached afterwards) ...")


class _CompileNotice(event.Listener):
    shown = False

    def on_start(self, ev):
        if self.shown:
            return
        data = ev.data if isinstance(ev.data, dict) else {}
        func = getattr(data.get("dispatcher"), "py_func", None)
        if getattr(func, "__module__", "").startswith("hoprover_env."):
            type(self).shown = True
            print(MESSAGE, file=sys.stderr, flush=True)

    def on_end(self, ev):
        pass


_installed = False


def install() -> None:
    """Listen for compilations of this package's kernels (once per process)."""
    global _installed
    if not _installed:
        event.register("numba:compile", _CompileNotice())
        _installed = True
