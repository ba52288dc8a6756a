"""A cold numba cache prints one progress line; a warm one prints nothing."""
import os
import subprocess
import sys

from hoprover_env._progress import MESSAGE


def test_one_progress_line_when_compiling_none_when_cached(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    code = "import hoprover_env"          # compiles the explicit-signature kernels
    cold = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True)
    assert cold.stderr.count(MESSAGE) == 1
    warm = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True)
    assert MESSAGE not in warm.stderr
