"""Importing any module of the package changes none of hoprover_env's public names:
`hoprover_env.simulate` stays the function and every name of `hoprover_env.__all__` the
object it was, whatever submodules are imported after the package (a submodule whose
name matched a public name, or an import hook aliasing old module paths, would replace
the attribute with a module). The package has no old module paths: each module is
imported at the one path it lives at, and the documented command lines run as modules."""

import json
import subprocess
import sys

import pytest

# the fast tier (pytest -m "not slow") leaves this file out:
# a fresh interpreter imports every module of the package (torch and Ray included)
pytestmark = pytest.mark.slow


PROBE = r"""
import importlib, importlib.util, json, pkgutil, sys
import hoprover_env

names = ["simulate", *hoprover_env.__all__]
before = {name: getattr(hoprover_env, name) for name in names}
hooks = [type(f).__module__ for f in sys.meta_path]
# what python -m needs of a module (before the walk: these two replace themselves in
# sys.modules with the module they run when imported)
runnable = {name: importlib.util.find_spec(name).loader.get_code(name) is not None
            for name in ("hoprover_env.compile", "hoprover_env.datasets")}
imported, missing = [], {}
def unimportable(name):
    raise ImportError(f"{name} could not be imported")
for info in pkgutil.walk_packages(hoprover_env.__path__, "hoprover_env.", onerror=unimportable):
    try:
        importlib.import_module(info.name)
    except ImportError as exc:       # an optional extra that is not installed
        if exc.name is None or exc.name.split(".")[0] == "hoprover_env":
            raise
        missing[info.name] = exc.name
        continue
    imported.append(info.name)
old = []
# old paths from before the package had layers: none imports, and trying changes nothing
for name in ("simulate", "batch", "params", "env", "reward", "cli", "policies", "_compile"):
    try:
        importlib.import_module(f"hoprover_env.{name}")
        old.append(name)
    except ModuleNotFoundError:
        pass
changed = sorted(name for name in names if getattr(hoprover_env, name) is not before[name])
print(json.dumps({"imported": imported, "missing": missing, "changed": changed,
                  "simulate": repr(type(hoprover_env.simulate)), "old": old,
                  "hooks": hooks, "runnable": runnable}))
"""


@pytest.fixture(scope="module")
def probe():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_importing_every_module_leaves_the_public_names_as_they_were(probe):
    assert len(probe["imported"]) > 60, probe["imported"]
    for name in (
        "hoprover_env.sim.simulate",
        "hoprover_env.envs.env",
        "hoprover_env.jit.compiler",
        "hoprover_env.compile",
    ):
        assert name in probe["imported"] or name in probe["missing"], name
    assert probe["changed"] == []
    assert probe["simulate"] == "<class 'function'>"


def test_there_are_no_old_module_paths_and_no_import_hook(probe):
    assert probe["old"] == []
    assert not [hook for hook in probe["hooks"] if hook.startswith("hoprover_env")]
    # the documented module command lines: python -m hoprover_env.compile, .datasets
    assert probe["runnable"] == {"hoprover_env.compile": True, "hoprover_env.datasets": True}
