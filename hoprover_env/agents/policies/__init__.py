"""The policy registry: every policy evaluate.py, train.py and the tests run, by name.

`load_policy` turns a name ("bundled", "scratch", "plan_clone", "scripted", "mpc",
"random", ...), an SB3 model or run directory, a torch module's .pt2 or
"module.py:Control" into a policy of one of the kinds in `hoprover_env.agents.base`
(re-exported here). The bundled models sit beside this file, each with a .json that says
how it was made. Every bundled file is self-describing: an SB3 zip (with its
VecNormalize statistics beside it), or a torch.export module that carries its own pre-
and post-processing, so no bundled policy needs code of its own in the package.
"""

from __future__ import annotations

import importlib.util
import json
import os
import pickle
from pathlib import Path

from hoprover_env.agents.base import (
    ArrayPolicy,
    ControllerPolicy,
    RandomPolicy,
    SB3Policy,
    TorchPolicy,
    torque_to_action,
)

__all__ = [
    "ArrayPolicy",
    "ControllerPolicy",
    "RandomPolicy",
    "SB3Policy",
    "TorchPolicy",
    "torque_to_action",
    "BUNDLED",
    "BUNDLED_NETS",
    "BUNDLED_DIR",
    "ALGOS",
    "SB3_ALGOS",
    "model_files",
    "load_sb3",
    "load_controller",
    "load_policy",
]

BUNDLED_DIR = Path(__file__).resolve().parent  # the bundled models beside this file
BUNDLED_NAME = "ppo_hoprover"
# the bundled models by name: cloned (+ PPO), PPO from scratch, PPO from scratch on the
# hop-level task, PPO on the terrain task (from scratch, then fine-tuned with a larger
# time cost: configs/ppo_terrain_fine.yaml; `terrain_base` is the run from scratch it
# started from, configs/ppo_terrain.yaml), and the from-scratch run stopped
# at 1.5 M steps (52 % of its validation targets: the medium agent of the offline
# datasets, hoprover_env.evaluation.datasets), and the hop network of the mission task
# (hoprover_env.agents.mission_hop: it acts through the estimator and a hopper); each file's
# .json says how it was trained
BUNDLED = {
    "bundled": "ppo_hoprover",
    "scratch": "ppo_scratch",
    "hop": "ppo_hop",
    "terrain": "ppo_terrain",
    "terrain_base": "ppo_terrain_base",
    "scratch_medium": "ppo_scratch_medium",
    "mission": "ppo_mission",
}
# bundled modules that are not SB3 models (TorchPolicy: a torch.export .pt2 that carries
# its own pre- and post-processing and metadata; the .json beside it repeats the
# metadata for people): the clone of the plan table with its nudge branch, made by the
# research pipeline in research/plan_clone/ of the repository
BUNDLED_NETS = {"plan_clone": "plan_clone"}
# the algorithms a model may be trained with (train.py's `algo`) and loaded with: name ->
# (module, class, the policy train.py builds); sb3-contrib's need the contrib extra
SB3_ALGOS = {
    "ppo": ("stable_baselines3", "PPO", "MlpPolicy"),
    "sac": ("stable_baselines3", "SAC", "MlpPolicy"),
    "td3": ("stable_baselines3", "TD3", "MlpPolicy"),
    "tqc": ("sb3_contrib", "TQC", "MlpPolicy"),
    "crossq": ("sb3_contrib", "CrossQ", "MlpPolicy"),
    "recurrentppo": ("sb3_contrib", "RecurrentPPO", "MlpLstmPolicy"),
}
ALGOS = tuple(SB3_ALGOS)
ALGO_NAMES = ", ".join(cls for _, cls, _ in SB3_ALGOS.values())  # for messages


# ---- loading ------------------------------------------------------------------------
def _algo_class(algo: str):
    """The SB3 class of `algo` (one of ALGOS). KeyError for another name; ImportError
    saying what to install when sb3-contrib is missing."""
    import importlib

    module, cls, _ = SB3_ALGOS[algo]
    try:
        return getattr(importlib.import_module(module), cls)
    except ImportError as err:
        raise ImportError(
            f"algo {algo!r} ({cls}) needs sb3-contrib: pip install 'hoprover[contrib]'"
        ) from err


def _bare_algo(path: Path) -> str:
    """The algorithm of an SB3 .zip without hoprover's metadata, read from the policy
    class saved in it (the most specific one that an algorithm of ALGOS builds): trying
    the classes in turn is ambiguous, SAC loads a TQC model and PPO a RecurrentPPO one.
    ValueError if it is none of them."""
    from stable_baselines3.common.save_util import load_from_zip_file

    try:
        data, _, _ = load_from_zip_file(str(path), device="cpu")
    except Exception as exc:  # noqa: BLE001 - a foreign file raises various errors
        raise ValueError(f"{path} is not an SB3 model ({type(exc).__name__}: {exc})") from None
    policy = (data or {}).get("policy_class")
    owners: dict = {}
    for algo in ALGOS:
        try:
            for cls in _algo_class(algo).policy_aliases.values():
                owners.setdefault(cls, algo)
        except ImportError:  # sb3-contrib missing: its models cannot be read
            continue
    for cls in getattr(policy, "__mro__", ()):
        if cls in owners:
            return owners[cls]
    raise ValueError(
        f"{path} is not a model of {ALGO_NAMES} (those of TQC, CrossQ and "
        "RecurrentPPO need sb3-contrib)"
    )


def model_files(spec: str | os.PathLike) -> tuple[Path, Path | None]:
    """(model .zip, its VecNormalize pickle or None) of an SB3 model: a bundled name
    ('terrain'), a run directory (its best model) or a .zip. Raises FileNotFoundError
    if the model is missing."""
    if str(spec) in BUNDLED:
        path = BUNDLED_DIR / f"{BUNDLED[str(spec)]}.zip"
        if not path.exists():
            raise FileNotFoundError(f"the bundled policy {str(spec)!r} is missing: {path}")
    else:
        path = Path(spec)
    if path.is_dir():
        for cand in ("best_model.zip", "final_model.zip"):
            if (path / cand).exists():
                path = path / cand
                break
        else:
            raise FileNotFoundError(f"no best_model.zip or final_model.zip in run directory {path}")
    if not path.exists():
        raise FileNotFoundError(f"model file not found: {path}")
    vn_path = path.with_name(path.stem + "_vecnormalize.pkl")
    if not vn_path.exists():
        vn_path = path.parent / "vecnormalize.pkl"
    return path, (vn_path if vn_path.exists() else None)


def load_sb3(path: str | os.PathLike, name: str | None = None) -> SB3Policy:
    """A model saved by train.py: a .zip (with its metadata JSON and VecNormalize pickle
    beside it), or a run directory (its best model), as an `SB3Policy` named `name`
    (default: the file's or directory's name).

    Raises FileNotFoundError if the file (or a run directory's model) is missing, and
    ValueError if a bare .zip is not a model of one of ALGOS (PPO, SAC, TD3, TQC, CrossQ,
    RecurrentPPO)."""
    if Path(path).is_dir():
        # every run directory holds a best_model.zip: the directory is what names the run
        name = name or Path(path).resolve().name
    path, vn_path = model_files(Path(path))
    meta_path = path.with_suffix(".json")
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    if meta.get("policy") == "mission_hop":  # a hop network: it acts through a hopper
        from hoprover_env.agents.mission_hop import load_mission_policy

        return load_mission_policy(path, name=name or path.stem)
    algo = meta.get("algo")
    if algo is None:  # a bare SB3 zip: its policy says which algorithm
        algo = _bare_algo(path)
    model = _algo_class(algo).load(str(path), device="cpu")
    obs_rms, clip = None, 10.0
    if vn_path is not None:
        with open(vn_path, "rb") as fh:
            vn = pickle.load(fh)
        obs_rms, clip = vn.obs_rms, vn.clip_obs
    return SB3Policy(
        model,
        obs_rms,
        clip,
        name=name or path.stem,
        env_kwargs=meta.get("env_kwargs", {}),
        env_id=meta.get("env_id", "HopRover-v0"),
    )


def load_controller(spec: str, control_dt: float = 0.5) -> ControllerPolicy:
    """'path/to/module.py:Control' -> a ControllerPolicy calling that function (or, if it
    is a class, one new instance per episode) every `control_dt` [s].

    Raises ValueError without a ':', FileNotFoundError for a missing module and
    AttributeError if the module has no such name."""
    if ":" not in spec:
        raise ValueError(f"--controller wants 'module.py:Function', got {spec!r}")
    file, attr = spec.rsplit(":", 1)
    if not os.path.exists(file):
        raise FileNotFoundError(f"controller module not found: {file}")
    mod_spec = importlib.util.spec_from_file_location(Path(file).stem, file)
    module = importlib.util.module_from_spec(mod_spec)
    mod_spec.loader.exec_module(module)
    if not hasattr(module, attr):
        raise AttributeError(f"{file} has no attribute {attr!r}")
    obj = getattr(module, attr)
    factory = obj if isinstance(obj, type) else (lambda: obj)
    return ControllerPolicy(
        factory, name=f"{Path(file).stem}:{attr}", env_kwargs={"control_dt": control_dt}
    )


def load_policy(spec: str, control_dt: float = 0.5, seed: int = 0):
    """A policy by name: 'bundled', 'scratch', 'hop', 'terrain', 'terrain_base',
    'mission' (the bundled models; 'mission' acts on HopRoverMission-v0's estimate,
    hoprover_env.agents.mission_hop),
    'plan_clone' (the bundled TorchPolicy; or any module's .pt2), 'scripted'
    (hoprover_env.agents.scripted.ScriptedHopper every `control_dt` [s]), 'random' (seeded with
    `seed`), a model .zip or run directory (`load_sb3`), or 'module.py:Control'
    (`load_controller`).

    Returns an SB3Policy, TorchPolicy, ControllerPolicy or RandomPolicy (or mpc's
    MPCPolicy): ``act(obs, venv)`` on a batch. Raises ValueError for an unknown name and
    FileNotFoundError for a missing file.
    """
    if spec in BUNDLED_NETS:
        return TorchPolicy.load(BUNDLED_DIR / f"{BUNDLED_NETS[spec]}.pt2", name=spec)
    if spec.endswith(".pt2"):
        return TorchPolicy.load(spec)
    if spec in BUNDLED:
        return load_sb3(model_files(spec)[0], name=spec)
    if spec == "scripted":
        from hoprover_env.agents.scripted import ScriptedHopper

        return ControllerPolicy(
            lambda: ScriptedHopper(control_dt=control_dt),
            name="scripted",
            env_kwargs={"control_dt": control_dt},
        )
    if spec == "random":
        return RandomPolicy(seed)
    if spec == "mpc":
        from hoprover_env.agents.mpc import MPCPolicy

        return MPCPolicy(seed=seed)
    if spec.endswith(".py") or ".py:" in spec:
        return load_controller(spec, control_dt)
    if os.path.exists(spec) or spec.endswith(".zip") or os.sep in spec:
        return load_sb3(spec)
    raise ValueError(
        f"unknown policy {spec!r}: use bundled, scratch, hop, terrain, "
        "terrain_base, mission, plan_clone, scripted, mpc, random, a model "
        ".zip or run directory, a .pt2, or module.py:Control"
    )
