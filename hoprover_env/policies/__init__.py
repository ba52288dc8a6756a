"""Policies that evaluate.py, train.py and the tests can run side by side.

Every policy acts on a batch: ``act(obs, venv) -> actions`` with obs of shape (N, 19)
from a `HopRoverVectorEnv` and actions in [-1, 1]^(N, 1). Kinds:

* ``SB3Policy`` -- a Stable-Baselines3 model (PPO, SAC, TD3) with the observation
  normalisation it was trained with (VecNormalize statistics), deterministic.
* ``ControllerPolicy`` -- any contest-signature controller
  ``Control(pos, vel, the, omg, posT, t, smt, state) -> torque``, one instance per
  sub-env, fed from the exact simulator state (no delay, as in the contest).
* ``RandomPolicy`` -- uniform random actions (a floor to compare against).
* ``ArrayPolicy`` -- any function from an observation batch to an action batch, e.g. a
  network trained with TorchRL, Tianshou or skrl (examples/).
* ``hoprover_env.gated.GatedPolicy`` -- a saved two-branch torch network (the bundled
  ``plan_clone``), raw observation in, action out.

`load_policy` turns a name ("bundled", "plan_clone", "scripted", "random", a model path,
a network's .pt or "module.py:Control") into one of these.
"""
from __future__ import annotations

import importlib.util
import json
import math
import os
import pickle
from pathlib import Path
from typing import Callable

import numpy as np

from hoprover_env import core
from hoprover_env.params import RoverParams

BUNDLED_DIR = Path(__file__).resolve().parent      # the bundled models beside this file
BUNDLED_NAME = "ppo_hoprover"
# the bundled models by name: cloned (+ PPO), PPO from scratch, PPO from scratch on the
# hop-level task, PPO on the terrain task (from scratch, then fine-tuned with a larger
# time cost: configs/ppo_terrain_fine.yaml; `terrain_base` is the run from scratch it
# started from, configs/ppo_terrain.yaml), and the from-scratch run stopped
# at 1.5 M steps (52 % of its validation targets: the medium agent of the offline
# datasets, hoprover_env.datasets), and the hop network of the mission task
# (hoprover_env.mission_hop: it acts through the estimator and a hopper); each file's
# .json says how it was trained
BUNDLED = {"bundled": "ppo_hoprover", "scratch": "ppo_scratch", "hop": "ppo_hop",
           "terrain": "ppo_terrain", "terrain_base": "ppo_terrain_base",
           "scratch_medium": "ppo_scratch_medium",
           "mission": "ppo_mission"}
# bundled networks that are not SB3 models: the plan-table clone with its nudge branch
# (hoprover_env.gated; .pt weights and .json metadata)
BUNDLED_NETS = {"plan_clone": "plan_clone"}
ALGOS = ("ppo", "sac", "td3")


class SB3Policy:
    """A trained SB3 model plus its observation normalisation, acting deterministically.

    Parameters: `model` (PPO, SAC or TD3); `obs_rms` the VecNormalize running statistics
    (None: observations unnormalised); `clip_obs` and `epsilon` as VecNormalize's; `name`
    for tables; `env_kwargs` the env arguments it was trained with (e.g. control_dt
    [s]); `env_id` the task it acts in (HopRoverHop-v0: one action per hop).
    """

    def __init__(self, model, obs_rms=None, clip_obs: float = 10.0, epsilon: float = 1e-8,
                 name: str = "sb3", env_kwargs: dict | None = None,
                 env_id: str = "HopRover-v0"):
        self.model, self.obs_rms = model, obs_rms
        self.clip_obs, self.epsilon = clip_obs, epsilon
        self.name = name
        self.env_kwargs = dict(env_kwargs or {})
        self.env_id = env_id             # the task it acts in (HopRoverHop-v0: one hop a step)

    def reset(self, n: int) -> None:
        """Start `n` episodes (the model keeps no per-episode state)."""

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """`obs` (N, 19) as the model saw them in training: standardised and clipped."""
        if self.obs_rms is None:
            return obs
        return np.clip((obs - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon),
                       -self.clip_obs, self.clip_obs).astype(np.float32)

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Deterministic actions (N, 1) for the observations `obs` (N, 19)."""
        action, _ = self.model.predict(self.normalize(obs), deterministic=True)
        return np.asarray(action, dtype=np.float64).reshape(len(obs), 1)


class ControllerPolicy:
    """Contest controllers, one per sub-env, driven from the simulator state.

    `factory()` makes one controller ``Control(pos, vel, the, omg, posT, t, smt, state)
    -> torque [N m]`` per episode; it sees the exact state (no delay, as in the
    contest), or on a task that hides the state (HopRoverMission-v0) the estimate of
    hoprover_env.estimation.MissionEstimator from the rover's readings, and plans on the
    ground the estimator knows of. `env_kwargs` set the env (e.g. control_dt [s]).
    """

    def __init__(self, factory: Callable[[], Callable], name: str = "controller",
                 env_kwargs: dict | None = None):
        self.factory = factory
        self.name = name
        self.env_kwargs = dict(env_kwargs or {})
        self.controllers: list = []

    def reset(self, n: int) -> None:
        """A fresh controller (and, on a task that hides its state, a fresh estimator)
        for each of `n` episodes."""
        from hoprover_env.estimation import EstimatorBank
        self.controllers = [self.factory() for _ in range(n)]
        self.estimates = EstimatorBank()
        self.estimates.reset(n)

    @property
    def estimators(self) -> list:
        return self.estimates.items

    def _inputs(self, obs: np.ndarray, venv):
        """Per sub-env, (controller inputs, the ground to plan on): from the exact
        state, or on a task that hides it (HopRoverMission-v0) from the estimate."""
        from hoprover_env.estimation import hides_state
        if hides_state(venv):
            return [(est.controller_inputs(float(venv.targets[i])), est.estimated_params())
                    for i, est in enumerate(self.estimates.update(obs, venv))]
        out = []
        for i in range(len(obs)):
            s = venv.S[i]
            out.append(((s[0:2].copy(), s[3:5].copy(), float(s[core.S_TH]),
                         float(s[core.S_W]), np.array([venv.targets[i], 0.0]),
                         float(s[core.S_T]), core.MODE_LETTERS[int(s[core.S_MODE])]),
                        venv.params[i]))
        return out

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Each controller's torque for its sub-env of `venv` (a HopRoverVectorEnv), as
        actions (N, 1). Raises ValueError if a controller returns a non-finite torque."""
        out = np.zeros((len(obs), 1))
        smt = venv.config.episode_time
        for i, (ctrl, ((pos, vel, the, omg, post, t, state), plan_params)) in enumerate(
                zip(self.controllers, self._inputs(obs, venv))):
            if hasattr(ctrl, "use_params"):      # a planner: the ground it knows of
                ctrl.use_params(plan_params)
            torque = float(ctrl(pos, vel, the, omg, post, t, smt, state))
            if not math.isfinite(torque):
                raise ValueError(f"{self.name}: the controller returned torque {torque!r}")
            out[i, 0] = torque_to_action(torque, plan_params, venv.config)
        return out


class ArrayPolicy:
    """`fn(obs) -> actions`, obs a float32 array (N, 19), actions anything of N values
    (numpy or torch): a policy trained by any library, judged like the others."""

    def __init__(self, fn: Callable, name: str = "policy", env_id: str = "HopRover-v0",
                 env_kwargs: dict | None = None):
        self.fn, self.name, self.env_id = fn, name, env_id
        self.env_kwargs = dict(env_kwargs or {})

    def reset(self, n: int) -> None:
        pass

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        out = self.fn(obs)
        out = out.detach().cpu().numpy() if hasattr(out, "detach") else out
        return np.clip(np.asarray(out, dtype=np.float64).reshape(len(obs), 1), -1.0, 1.0)


class RandomPolicy:
    """Uniform random actions in [-1, 1]: a floor to compare against. `seed` (int)
    makes the draws reproducible per batch of episodes."""

    def __init__(self, seed: int = 0):
        self.name = "random"
        self.env_kwargs = {}
        self.seed = seed
        self.rng = np.random.default_rng(seed)

    def reset(self, n: int, first_episode: int = 0) -> None:
        """Start `n` episodes; the first is episode `first_episode` of the evaluation."""
        # a stream per batch of episodes, keyed by its first episode: the same draws
        # whichever process evaluates that batch (evaluate.py --ray)
        self.rng = np.random.default_rng([self.seed, first_episode])

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Uniform random actions (N, 1)."""
        return self.rng.uniform(-1.0, 1.0, (len(obs), 1))


def torque_to_action(torque: float, params: RoverParams, config=None) -> float:
    """The inverse of the env's action map (`tasks.torque.action_to_torque`; linear unless
    the env config says otherwise), clipped to [-1, 1]."""
    lo, hi = params.torque_min, params.torque_max
    amap = getattr(config, "action_map", "linear")
    scale = getattr(config, "action_scale", 1.0)
    t = torque / scale
    if amap == "cubic":
        ref = hi if t >= 0.0 else -lo
        if ref <= 0.0:
            return 0.0
        return float(np.clip(np.cbrt(t / ref), -1.0, 1.0))
    if hi == lo:
        return 0.0
    return float(np.clip(2.0 * (t - lo) / (hi - lo) - 1.0, -1.0, 1.0))


# ---- loading ------------------------------------------------------------------------
def _algo_class(algo: str):
    from stable_baselines3 import PPO, SAC, TD3
    return {"ppo": PPO, "sac": SAC, "td3": TD3}[algo]


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
    ValueError if a bare .zip is not a PPO, SAC or TD3 model."""
    if Path(path).is_dir():
        # every run directory holds a best_model.zip: the directory is what names the run
        name = name or Path(path).resolve().name
    path, vn_path = model_files(Path(path))
    meta_path = path.with_suffix(".json")
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    if meta.get("policy") == "mission_hop":      # a hop network: it acts through a hopper
        from hoprover_env.mission_hop import load_mission_policy
        return load_mission_policy(path, name=name or path.stem)
    algo = meta.get("algo")
    if algo is None:                   # a bare SB3 zip: try the algorithms in turn
        for cand in ALGOS:
            try:
                model = _algo_class(cand).load(str(path), device="cpu")
                algo = cand
                break
            except Exception:          # noqa: BLE001 - the wrong class raises various errors
                continue
        else:
            raise ValueError(f"{path} is not a PPO, SAC or TD3 model")
    else:
        model = _algo_class(algo).load(str(path), device="cpu")
    obs_rms, clip = None, 10.0
    if vn_path is not None:
        with open(vn_path, "rb") as fh:
            vn = pickle.load(fh)
        obs_rms, clip = vn.obs_rms, vn.clip_obs
    return SB3Policy(model, obs_rms, clip, name=name or path.stem,
                     env_kwargs=meta.get("env_kwargs", {}),
                     env_id=meta.get("env_id", "HopRover-v0"))


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
    return ControllerPolicy(factory, name=f"{Path(file).stem}:{attr}",
                            env_kwargs={"control_dt": control_dt})


def load_policy(spec: str, control_dt: float = 0.5, seed: int = 0):
    """A policy by name: 'bundled', 'scratch', 'hop', 'terrain', 'terrain_base',
    'mission' (the bundled models; 'mission' acts on HopRoverMission-v0's estimate,
    hoprover_env.mission_hop),
    'plan_clone' (the bundled gated network, hoprover_env.gated; or any saved one's
    .pt), 'scripted'
    (hoprover_env.scripted.ScriptedHopper every `control_dt` [s]), 'random' (seeded with
    `seed`), a model .zip or run directory (`load_sb3`), or 'module.py:Control'
    (`load_controller`).

    Returns an SB3Policy, GatedPolicy, ControllerPolicy or RandomPolicy (or mpc's
    MPCPolicy): ``act(obs, venv)`` on a batch. Raises ValueError for an unknown name and
    FileNotFoundError for a missing file.
    """
    if spec in BUNDLED_NETS or spec.endswith(".pt"):
        from hoprover_env import gated
        path = BUNDLED_DIR / f"{BUNDLED_NETS[spec]}.pt" if spec in BUNDLED_NETS else Path(spec)
        net, meta = gated.load(path)
        return gated.GatedPolicy(net, name=spec if spec in BUNDLED_NETS else path.stem,
                                 env_kwargs=meta["env_kwargs"])
    if spec in BUNDLED:
        return load_sb3(model_files(spec)[0], name=spec)
    if spec == "scripted":
        from hoprover_env.scripted import ScriptedHopper
        return ControllerPolicy(lambda: ScriptedHopper(control_dt=control_dt), name="scripted",
                                env_kwargs={"control_dt": control_dt})
    if spec == "random":
        return RandomPolicy(seed)
    if spec == "mpc":
        from hoprover_env.mpc import MPCPolicy
        return MPCPolicy(seed=seed)
    if spec.endswith(".py") or ".py:" in spec:
        return load_controller(spec, control_dt)
    if os.path.exists(spec) or spec.endswith(".zip") or os.sep in spec:
        return load_sb3(spec)
    raise ValueError(f"unknown policy {spec!r}: use bundled, scratch, hop, terrain, terrain_base, mission, plan_clone, scripted, mpc, random, a model "
                     ".zip or run directory, or module.py:Control")
