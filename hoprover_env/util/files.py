"""Result files of train.py and evaluate.py: written whole or not at all, as strict JSON."""

from __future__ import annotations

import json
import math
import os
import tempfile


def atomic_write(path: str | os.PathLike, text: str | bytes) -> None:
    """Write `text` (or bytes) via a temporary file in the same directory and rename:
    never half a file."""
    path = os.path.abspath(path)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), prefix=".tmp-")
    try:
        # mkstemp creates 0600 and the rename keeps it: give the file what open() would
        os.fchmod(fd, 0o666 & ~_umask())
        with (
            os.fdopen(fd, "wb") if isinstance(text, bytes) else os.fdopen(fd, "w", newline="")
        ) as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)  # reading the umask means setting it: put it straight back
    os.umask(mask)
    return mask


def _nan_to_none(obj):
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _nan_to_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_nan_to_none(v) for v in obj]
    return obj


def write_npz(path: str | os.PathLike, **arrays) -> None:
    """numpy arrays as one .npz, atomically (a killed writer leaves no half archive)."""
    import io

    import numpy as np

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write(path, buf.getvalue())


def write_json(path: str | os.PathLike, obj) -> None:
    """Strict JSON, atomically: a statistic with no value (NaN, e.g. the median TTRTP of a
    policy that never succeeded) is written as null, which every JSON parser accepts."""
    atomic_write(path, json.dumps(_nan_to_none(obj), indent=1, allow_nan=False))
