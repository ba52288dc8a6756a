"""A small pool of worker processes for work that Python's threads cannot share: calls
``fn(*args)`` (both picklable) run in fresh interpreters, their results handed back as
they finish.

Why not `multiprocessing`: its "spawn" start re-runs the caller's main script in every
worker (as ``__mp_main__``), so a script that calls into hoprover at its top level,
without an ``if __name__ == "__main__"`` guard, would start workers from its workers and
fail; and "fork" copies a process whose threads (numba's, torch's, BLAS pools) may hold
locks. Here each worker is ``python -m hoprover_env.evaluation.workers``: it imports
hoprover and nothing of the caller's but what the pickled calls name, on the caller's
``sys.path``. Calls and results travel as length-prefixed pickles over the worker's
stdin and stdout (its prints go to stderr). One thread per worker in the calling
process waits on its pipe (without the GIL); they are joined before `run` returns.
"""

from __future__ import annotations

import os
import pickle
import queue
import struct
import subprocess
import sys
import threading
import traceback
from typing import Any

_HEAD = struct.Struct("<Q")
# the worker's own module, run with -m: importable from the directory above the package
_PACKAGE_PARENT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class WorkerError(RuntimeError):
    """A worker process died or could not start (not: a call that raised, whose own
    exception `run` raises again)."""


def _send(stream, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEAD.pack(len(data)))
    stream.write(data)
    stream.flush()


def _recv(stream):
    head = stream.read(_HEAD.size)
    if len(head) < _HEAD.size:
        raise EOFError
    (size,) = _HEAD.unpack(head)
    data = stream.read(size)
    if len(data) < size:
        raise EOFError
    return pickle.loads(data)


def run(calls, workers: int, setup=None):
    """Run `calls` (a list of (fn, args)) in `workers` worker processes, each call handed
    to the next worker free; yields (index in `calls`, result) in the order they finish.
    `setup` (fn, args) runs once in each worker first. A call that raises stops the
    others from starting and is raised here again, its worker's traceback attached as
    a note; a worker that dies raises WorkerError. Leaving the generator early (a break,
    an exception) stops the workers."""
    todo: queue.Queue = queue.Queue()
    for k, call in enumerate(calls):
        todo.put((k, call))
    done: queue.Queue = queue.Queue()
    stop = threading.Event()
    procs: list = []
    lock = threading.Lock()
    env = dict(
        os.environ,
        PYTHONPATH=os.pathsep.join(p for p in (_PACKAGE_PARENT, os.environ.get("PYTHONPATH")) if p),
    )

    def drive():
        try:
            proc = subprocess.Popen(
                [sys.executable, "-m", "hoprover_env.evaluation.workers"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                env=env,
            )
        except OSError as exc:
            done.put((None, ("died", f"could not start a worker process: {exc}")))
            return
        with lock:
            procs.append(proc)
        try:
            _send(proc.stdin, (list(sys.path), setup))
            while not stop.is_set():
                try:
                    k, call = todo.get_nowait()
                except queue.Empty:
                    break
                _send(proc.stdin, call)
                done.put((k, _recv(proc.stdout)))
            _send(proc.stdin, None)  # no more: the worker exits
            proc.stdin.close()
            proc.wait()
        except (EOFError, OSError):
            if not stop.is_set():
                done.put(
                    (
                        None,
                        (
                            "died",
                            f"a worker process exited (code {proc.poll()}) "
                            "before returning its result",
                        ),
                    )
                )
        finally:
            if proc.poll() is None and stop.is_set():
                proc.kill()
                proc.wait()

    threads = [threading.Thread(target=drive, daemon=True) for _ in range(workers)]
    for t in threads:
        t.start()
    try:
        for _ in range(len(calls)):
            k, (status, *rest) = done.get()
            if status == "ok":
                yield k, rest[0]
            elif status == "error":
                exc, tb = rest
                if hasattr(exc, "add_note"):
                    exc.add_note("in a worker process:\n" + tb)
                raise exc
            else:
                raise WorkerError(rest[0])
    finally:
        stop.set()
        with lock:
            for proc in procs:  # those still in a call stop now
                if proc.poll() is None:
                    proc.kill()
        for t in threads:
            t.join()


def _serve() -> None:
    """The worker: the caller's sys.path and setup, then calls until told to stop."""
    stdin = sys.stdin.buffer
    out = os.fdopen(os.dup(1), "wb")  # the results' channel, kept apart ...
    os.dup2(2, 1)  # ... from anything printed (to stderr)
    path, setup = _recv(stdin)
    sys.path[:] = path + [p for p in sys.path if p not in path]
    if setup is not None:
        setup[0](*setup[1])
    while True:
        try:
            call = _recv(stdin)
        except EOFError:
            return
        if call is None:
            return
        fn, args = call
        result: tuple[Any, ...]
        try:
            result = ("ok", fn(*args))
        except BaseException as exc:  # noqa: BLE001 - handed back to the caller
            result = ("error", exc, traceback.format_exc())
        try:
            _send(out, result)
        except Exception as exc:  # noqa: BLE001 - something would not pickle
            _send(
                out,
                (
                    "error",
                    RuntimeError(
                        f"a worker's result could not be sent back: {type(exc).__name__}: {exc}"
                    ),
                    traceback.format_exc(),
                ),
            )


if __name__ == "__main__":
    _serve()
