"""Which hoprover this process runs: version, git commit and a hash of the code itself.

A Ray cluster runs tasks on other machines, each with its own hoprover installed.
`build_info()` says what this process imports; hoprover_env/training/ray_utils.py compares
the driver's with every node's and refuses to start when they differ. The comparison is on the
version and the source hash, not the commit: a hash of the files works the same for a
git checkout, an editable install, a wheel in a container image or a copy Ray shipped,
and it catches uncommitted edits that a commit id would not. The commit is reported for
people (from git when the code is a checkout; None otherwise).

`use_checkout` is the Ray worker setup hook for an installed checkout: it puts the
checkout's root (train.py, and the drivers beside it) on sys.path, next to the installed
hoprover_env. The hash covers the package alone: the drivers and research pipelines
beside it in a checkout are not hoprover's code.
"""

from __future__ import annotations

import functools
import hashlib
import os
import socket
import subprocess
import sys
from pathlib import Path

VERSION = "0.1.0"  # hoprover_env.__version__
PACKAGE = Path(__file__).resolve().parent.parent
# a checkout's root, when hoprover_env was installed from one (pip install -e .)
CHECKOUT = PACKAGE.parent
DATA_SUFFIXES = (".zip", ".pkl", ".json", ".pt")  # the bundled policies (package data)


def _checkout_root() -> Path | None:
    root = CHECKOUT
    return root if (root / "pyproject.toml").is_file() and (root / "train.py").is_file() else None


def _code_files() -> list[Path]:
    """What a task runs: the package's sources and bundled policies. Never caches
    (__pycache__) or stray files."""
    files = [p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts]
    files += [p for p in (PACKAGE / "agents" / "policies").glob("*") if p.suffix in DATA_SUFFIXES]
    return sorted(files)


def source_hash() -> str:
    """sha256 over the relative paths and bytes of the code files (12 hex digits)."""
    base = PACKAGE.parent
    h = hashlib.sha256()
    for path in _code_files():
        h.update(str(path.relative_to(base).as_posix()).encode() + b"\0")
        h.update(path.read_bytes())
    return h.hexdigest()[:12]


def git_commit(root: str | os.PathLike | None = None) -> str | None:
    """The commit of the checkout at root (with '+dirty' if it has uncommitted changes
    to tracked files), or None when it is not a git checkout or git is missing."""
    root = Path(root) if root is not None else CHECKOUT
    try:
        rev = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10
        )
        if rev.returncode != 0:
            return None
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    rev = rev.stdout.strip()
    return (rev + ("+dirty" if dirty.strip() else "")) if rev else None


@functools.lru_cache(maxsize=1)
def build_info() -> dict:
    """{'version', 'commit', 'source', 'path', 'checkout'} of the hoprover this process
    imports; 'checkout' says whether train.py is there (sweeps and
    evaluate.py's tasks need them)."""
    # the commit of the checkout only when the package is that checkout's, not of
    # whatever git repository a site-packages happens to sit in
    root = _checkout_root()
    return {
        "version": VERSION,
        "commit": git_commit(root) if root else None,
        "source": source_hash(),
        "path": str(PACKAGE),
        "checkout": root is not None,
    }


def probe() -> dict:
    """build_info() as a node sees it, with the node's name (a Ray task runs this)."""
    return {**build_info(), "host": socket.gethostname(), "python": sys.version.split()[0]}


def mismatch(expected: dict, seen: dict) -> str | None:
    """Why `seen` (a node's probe) cannot run the driver's work, or None."""
    if seen.get("version") != expected["version"] or seen.get("source") != expected["source"]:
        return (
            f"hoprover {seen.get('version')} (source {seen.get('source')}, commit "
            f"{seen.get('commit')}) at {seen.get('path')}, but the driver has "
            f"{expected['version']} (source {expected['source']}, commit "
            f"{expected['commit']})"
        )
    if expected.get("checkout") and not seen.get("checkout"):
        return (
            f"hoprover at {seen.get('path')} is installed without its checkout "
            "(train.py): install it from a checkout with pip install -e"
        )
    return None


def require(expected: dict) -> None:
    """Raise in a task whose node runs other code than the driver (a node that joined
    after the start-up check)."""
    why = mismatch(expected, probe())
    if why is not None:
        raise RuntimeError(
            f"node {socket.gethostname()} runs {why}. Install the driver's "
            "hoprover on every node, or pass --ship-code"
        )


def use_checkout() -> None:
    """Ray worker setup hook: the checkout this hoprover_env was installed from goes on
    sys.path, so that tasks import its research/ and train.py as well."""
    root = _checkout_root()
    if root is not None and str(root) not in sys.path:
        sys.path.insert(0, str(root))
