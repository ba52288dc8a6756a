"""Registration is Gymnasium's: the package's env classes are written out (importable,
inspectable, picklable by name), a task module outside the package registers itself on
import (``gym.make("module:Id-v0")``), an installed package registers its tasks through
the ``hoprover.tasks`` entry points, and the lookups by id read the registry when
called. A task names its suite, or has none."""

import inspect
import os
import pickle
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import hoprover_env
from hoprover_env.envs import registry
from hoprover_env.envs.env import HopRoverEnv
from hoprover_env.envs.vector_env import HopRoverVectorEnv
from hoprover_env.evaluation import suites
from hoprover_env.tasks import Registration

TESTS = Path(__file__).resolve().parents[1]  # where toy_task.py lives

# a task module of its own that reuses the toy task's TASK under another id
PLUGIN = """
import toy_task
from hoprover_env import register_task
from hoprover_env.tasks import Registration

TASK = toy_task.TASK
REGISTER = (Registration("{id}", {{"episode_time": 60.0}}, suite={suite!r}),)

register_task(__name__)
"""


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """Write a task module `name` registering `env_id`; forget its ids afterwards."""
    monkeypatch.syspath_prepend(str(TESTS))
    monkeypatch.syspath_prepend(str(tmp_path))
    made = []

    def write(name, env_id, suite=None):
        (tmp_path / f"{name}.py").write_text(PLUGIN.format(id=env_id, suite=suite))
        made.append((name, env_id))
        return env_id

    yield write
    for name, env_id in made:
        registry.ENVS.pop(env_id, None)
        gym.registry.pop(env_id, None)
        sys.modules.pop(name, None)


@pytest.mark.parametrize(
    "env_id", ["HopRoverHop-v0", "HopRoverTerrain-v0", "HopRoverMission-v0", "HopRoverRL-v1"]
)
def test_the_packages_env_classes_are_written_out_and_pickle_by_name(env_id):
    env_cls, vec_cls = registry.env_class(env_id), registry.vector_env_class(env_id)
    for cls, base in ((env_cls, HopRoverEnv), (vec_cls, HopRoverVectorEnv)):
        assert cls.__module__ == "hoprover_env.envs.tasks"
        assert f"class {cls.__name__}(" in inspect.getsource(cls)
        assert (
            issubclass(cls, base)
            and cls.task is registry.task_module(registry.task(env_id).module).TASK
        )
        assert getattr(hoprover_env, cls.__name__) is cls  # a public name
        assert getattr(registry, cls.__name__) is cls  # the old path too
        assert cls.__doc__ and registry.task(env_id).module in cls.__doc__
    env = gym.make(env_id).unwrapped
    env.reset(seed=1)
    copy = pickle.loads(pickle.dumps(env))
    assert type(copy) is env_cls
    np.testing.assert_array_equal(copy._s, env._s)
    vec = vec_cls(num_envs=2)
    vec.reset(seed=2)
    assert type(pickle.loads(pickle.dumps(vec))) is vec_cls


def test_a_task_module_registers_itself_when_gymnasium_imports_it(plugin):
    env_id = plugin("tip_plugin", "HopRoverTipPlugin-v0")
    assert "tip_plugin" not in sys.modules and env_id not in gym.registry
    env = gym.make(f"tip_plugin:{env_id}")  # Gymnasium's module:id import
    assert type(env.unwrapped).__name__ == "HopRoverTipPluginEnv"
    assert type(env.unwrapped).__module__ == "tip_plugin"  # stored in its module
    assert env.unwrapped.config.episode_time == 60.0
    env.reset(seed=0)
    assert type(pickle.loads(pickle.dumps(env.unwrapped))).__name__ == "HopRoverTipPluginEnv"
    assert hoprover_env.register_task("tip_plugin") == [env_id]  # again: no change
    assert registry.env_class(env_id) is type(env.unwrapped)
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    assert type(vec).__name__ == "HopRoverTipPluginVectorEnv"


def test_the_toy_task_registers_itself_on_import():
    code = (
        "import gymnasium as gym; env = gym.make('toy_task:HopRoverTip-v0'); "
        "print(type(env.unwrapped).__module__, type(env.unwrapped).__name__)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        cwd=TESTS,
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    assert out.stdout.split() == ["toy_task", "HopRoverTipEnv"]


def _dist_info(root: Path, entries: dict[str, str]) -> None:
    info = root / "hoprover_tips-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: hoprover-tips\nVersion: 0.1\n")
    lines = "".join(f"{name} = {value}\n" for name, value in entries.items())
    (info / "entry_points.txt").write_text(f"[hoprover.tasks]\n{lines}")


def test_an_installed_package_registers_its_tasks_through_entry_points(plugin, tmp_path):
    env_id = plugin("tip_installed", "HopRoverTipInstalled-v0")
    _dist_info(tmp_path, {"tip": "tip_installed", "broken": "no_such_task_module"})
    with pytest.warns(RuntimeWarning, match="no_such_task_module"):
        ids = registry.register_installed()
    assert ids == [env_id] and env_id in gym.registry
    assert gym.make(env_id).unwrapped.config.episode_time == 60.0


def test_importing_hoprover_env_registers_installed_tasks(tmp_path):
    (tmp_path / "tip_installed.py").write_text(
        PLUGIN.format(id="HopRoverTipInstalled-v0", suite=None)
    )
    _dist_info(tmp_path, {"tip": "tip_installed"})
    code = (
        "import gymnasium as gym, hoprover_env; "
        "print(type(gym.make('HopRoverTipInstalled-v0').unwrapped).__name__)"
    )
    path = os.pathsep.join([str(tmp_path), str(TESTS)])
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
        env={**os.environ, "PYTHONPATH": path},
    )
    assert out.stdout.split()[-1] == "HopRoverTipInstalledEnv"


def test_a_task_has_no_suite_until_it_names_one(plugin):
    assert Registration("X-v0").suite is None
    for spec in registry.ENVS.values():  # the package's ids name theirs
        if spec.module.startswith("hoprover_env."):
            assert spec.suite in ("level", "terrain", "contest")
    bare = plugin("tip_bare", "HopRoverTipBare-v0")
    hoprover_env.register_task("tip_bare")
    with pytest.raises(ValueError, match="HopRoverTipBare-v0.*no test suite"):
        suites.load(bare)
    assert bare not in suites.suite_ids()


def test_suite_lookups_read_the_registry_when_called(plugin):
    before = suites.suite_ids("level")
    env_id = plugin("tip_level", "HopRoverTipLevel-v0", suite="level")
    hoprover_env.register_task("tip_level")
    assert suites.suite_ids("level") == [*before, env_id]
    assert suites.suite_of(env_id) == "level"
    assert suites.task_of("level") == "HopRover-v0"
    assert suites.load(env_id).name == "level"
    with pytest.raises(ValueError, match="unknown hoprover env id"):
        suites.suite_of("NoSuch-v0")
