"""Old module paths of hoprover_env, kept importable after the package was grouped by layer.

Until version 0.1 every module sat at the top of `hoprover_env` (`hoprover_env.params`,
`hoprover_env.env`, ...). They now live in one subpackage per layer (docs/ARCHITECTURE.md).
Code written against the old paths keeps working: importing `hoprover_env.params` returns
the module `hoprover_env.core.params` itself (the same object, so a monkeypatch or an
isinstance check sees one module) and emits a DeprecationWarning that names the
preferred path. docs/changelog.md lists every move.

One table and one import hook, instead of forty files that each re-export a module: the
hook answers only for the names in `MOVED`, and only below `hoprover_env`.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

# old path -> preferred path (relative to hoprover_env)
MOVED = {
    "_compile": "jit.compiler", "_numba_layer": "jit.numba_layer",
    "_dop853_tableau": "core._dop853_tableau", "params": "core.params",
    "validate": "util.validate", "files": "util.files", "buildinfo": "util.buildinfo",
    "simulate": "sim.simulate", "batch": "sim.batch", "rollout": "sim.rollout",
    "controllers": "sim.controllers", "reference": "sim.reference", "testing": "sim.testing",
    "env_config": "tasks.config", "reward": "tasks.reward",
    "env": "envs.env", "vector_env": "envs.vector_env", "env_parts": "envs.parts",
    "hop_env": "envs.registry", "terrain_env": "envs.registry",
    "mission_env": "envs.registry", "rendering": "envs.rendering", "sb3": "envs.sb3",
    "rllib": "envs.rllib",
    "scripted": "agents.scripted", "compiled": "agents.compiled", "mpc": "agents.mpc",
    "planning": "agents.planning", "estimation": "agents.estimation",
    "mission_hop": "agents.mission_hop", "policies": "agents.policies",
    "suites": "evaluation.suites", "scores": "evaluation.scores",
    "replay": "evaluation.replay", "plots": "evaluation.plots",
    "cli": "training", "cli.train": "training.train", "cli.evaluate": "training.evaluate",
    "cli.sweep": "training.sweep", "sb3_agents": "training.sb3_agents",
    "imitation": "training.imitation", "ray_utils": "training.ray_utils",
    "ray_eval": "training.ray_eval",
}
PACKAGE = "hoprover_env"


class MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Import hook: `hoprover_env.<old>` is the module at its new path."""

    def __init__(self):
        self.specs = {}                         # each moved module's own spec, by name

    def find_spec(self, fullname, path=None, target=None):
        prefix = PACKAGE + "."
        if fullname.startswith(prefix) and fullname[len(prefix):] in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        new = f"{PACKAGE}.{MOVED[spec.name[len(PACKAGE) + 1:]]}"
        warnings.warn(f"{spec.name} moved to {new}; import it from there (the old path "
                      "will be removed in a future release)", DeprecationWarning,
                      stacklevel=2)    # warnings skips the import system's frames
        module = importlib.import_module(new)
        self.specs[module.__name__] = module.__spec__
        return module

    def exec_module(self, module) -> None:
        # the module is loaded already; the import system has just set its __spec__ to
        # the old name's, so give it back its own (pickle, reload and runpy read it)
        module.__spec__ = self.specs[module.__name__]


def install() -> None:
    """Put the hook first on sys.meta_path, once per process."""
    if not any(isinstance(f, MovedModules) for f in sys.meta_path):
        sys.meta_path.insert(0, MovedModules())
