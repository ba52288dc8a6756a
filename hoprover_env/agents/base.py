"""The kinds of policy every driver runs, and the one conversion they share.

Every policy acts on a batch: ``act(obs, venv) -> actions`` with obs of shape (N, obs_dim)
from a hoprover vector env and actions in [-1, 1]^(N, action_dim); ``reset(n)`` starts
n episodes; ``name`` labels tables; ``env_id`` and ``env_kwargs`` say which task and
settings it acts in.

* ``SB3Policy`` -- a Stable-Baselines3 model with the observation normalisation it was
  trained with (VecNormalize statistics), deterministic; a recurrent one (RecurrentPPO)
  keeps its memory per episode.
* ``TorchPolicy`` -- a self-describing torch module (``torch.export``, .pt2) that maps raw
  observations to actions, pre- and post-processing included; its metadata travels in
  the file.
* ``ControllerPolicy`` -- any contest-signature controller
  ``Control(pos, vel, the, omg, posT, t, smt, state) -> torque``, one instance per
  sub-env, fed from the exact simulator state (no delay, as in the contest).
* ``ArrayPolicy`` -- any function from an observation batch to an action batch.
* ``RandomPolicy`` -- uniform random actions (a floor to compare against).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from hoprover_env import core
from hoprover_env.core.params import RoverParams
from hoprover_env.tasks.torque import torque_to_action as _torque_to_action


class SB3Policy:
    """A trained SB3 model plus its observation normalisation, acting deterministically.

    Parameters: `model` (PPO, SAC, TD3, TQC, CrossQ or RecurrentPPO); `obs_rms` the
    VecNormalize running statistics (None: observations unnormalised); `clip_obs` and
    `epsilon` as VecNormalize's; `name` for tables; `env_kwargs` the env arguments it was
    trained with (e.g. control_dt [s]); `env_id` the task it acts in (HopRoverHop-v0: one
    action per hop).

    A recurrent model (an LSTM policy) keeps its memory per sub-env of the batch: `reset(n)`
    empties it for all n, `restart(slots)` for the slots whose sub-env starts a new
    episode within the batch (a driver that refills finished slots calls it).
    """

    def __init__(
        self,
        model,
        obs_rms=None,
        clip_obs: float = 10.0,
        epsilon: float = 1e-8,
        name: str = "sb3",
        env_kwargs: dict | None = None,
        env_id: str = "HopRover-v0",
    ):
        self.model, self.obs_rms = model, obs_rms
        self.clip_obs, self.epsilon = clip_obs, epsilon
        self.name = name
        self.env_kwargs = dict(env_kwargs or {})
        self.env_id = env_id  # the task it acts in (HopRoverHop-v0: one hop a step)
        # sb3-contrib's recurrent policies carry the shape of their memory
        self.recurrent = hasattr(getattr(model, "policy", None), "lstm_hidden_state_shape")
        self.state = None  # the LSTM's (hidden, cell) per sub-env
        self.episode_start = None  # per sub-env: its memory starts over at this step

    def reset(self, n: int) -> None:
        """Start `n` episodes (a recurrent model's memory starts empty in each; other
        models keep no per-episode state)."""
        if self.recurrent:
            self.state, self.episode_start = None, np.ones(n, dtype=bool)

    def restart(self, slots) -> None:
        """New episodes in `slots` (indices or a boolean mask of the batch): a recurrent
        model forgets what it saw there."""
        if self.recurrent and self.episode_start is not None:
            self.episode_start[slots] = True

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """`obs` (N, 19) as the model saw them in training: standardised and clipped."""
        if self.obs_rms is None:
            return obs
        return np.clip(
            (obs - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon),
            -self.clip_obs,
            self.clip_obs,
        ).astype(np.float32)

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Deterministic actions (N, 1) for the observations `obs` (N, 19)."""
        if not self.recurrent:
            action, _ = self.model.predict(self.normalize(obs), deterministic=True)
        else:
            if self.episode_start is None or len(self.episode_start) != len(obs):
                self.reset(len(obs))  # acting without reset: a fresh batch
            action, self.state = self.model.predict(
                self.normalize(obs),
                state=self.state,
                episode_start=self.episode_start,
                deterministic=True,
            )
            self.episode_start = np.zeros(len(obs), dtype=bool)
        return np.asarray(action, dtype=np.float64).reshape(len(obs), 1)


class ControllerPolicy:
    """Contest controllers, one per sub-env, driven from the simulator state.

    `factory()` makes one controller ``Control(pos, vel, the, omg, posT, t, smt, state)
    -> torque [N m]`` per episode; it sees the exact state (no delay, as in the
    contest), or on a task that hides the state (HopRoverMission-v0) the estimate of
    hoprover_env.agents.estimation.MissionEstimator from the rover's readings, and plans on the
    ground the estimator knows of. `env_kwargs` set the env (e.g. control_dt [s]).
    """

    def __init__(
        self,
        factory: Callable[[], Callable],
        name: str = "controller",
        env_kwargs: dict | None = None,
    ):
        self.factory = factory
        self.name = name
        self.env_kwargs = dict(env_kwargs or {})
        self.controllers: list = []

    def reset(self, n: int) -> None:
        """A fresh controller (and, on a task that hides its state, a fresh estimator)
        for each of `n` episodes."""
        from hoprover_env.agents.estimation import EstimatorBank

        self.controllers = [self.factory() for _ in range(n)]
        self.estimates = EstimatorBank()
        self.estimates.reset(n)

    @property
    def estimators(self) -> list:
        return self.estimates.items

    def _inputs(self, obs: np.ndarray, venv):
        """Per sub-env, (controller inputs, the ground to plan on): from the exact
        state, or on a task that hides it (HopRoverMission-v0) from the estimate."""
        from hoprover_env.agents.estimation import hides_state

        if hides_state(venv):
            return [
                (est.controller_inputs(float(venv.targets[i])), est.estimated_params())
                for i, est in enumerate(self.estimates.update(obs, venv))
            ]
        out = []
        for i in range(len(obs)):
            s = venv.S[i]
            out.append(
                (
                    (
                        s[0:2].copy(),
                        s[3:5].copy(),
                        float(s[core.S_TH]),
                        float(s[core.S_W]),
                        np.array([venv.targets[i], 0.0]),
                        float(s[core.S_T]),
                        core.MODE_LETTERS[int(s[core.S_MODE])],
                    ),
                    venv.params[i],
                )
            )
        return out

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Each controller's torque for its sub-env of `venv` (a HopRoverVectorEnv), as
        actions (N, 1). Raises ValueError if a controller returns a non-finite torque."""
        out = np.zeros((len(obs), 1))
        smt = venv.config.episode_time
        invert = venv.task.torque_action  # the inverse of the task's action map
        if invert is None:
            raise ValueError(
                f"{self.name}: a contest controller commands torques, and "
                f"the actions of {type(venv).__name__} are not torques"
            )
        for i, (ctrl, ((pos, vel, the, omg, post, t, state), plan_params)) in enumerate(
            zip(self.controllers, self._inputs(obs, venv))
        ):
            if hasattr(ctrl, "use_params"):  # a planner: the ground it knows of
                ctrl.use_params(plan_params)
            torque = float(ctrl(pos, vel, the, omg, post, t, smt, state))
            if not math.isfinite(torque):
                raise ValueError(f"{self.name}: the controller returned torque {torque!r}")
            out[i, 0] = invert(torque, plan_params, venv.config)
        return out


class ArrayPolicy:
    """`fn(obs) -> actions`, obs a float32 array (N, 19), actions anything of N values
    (numpy or torch): a policy trained by any library, judged like the others."""

    def __init__(
        self,
        fn: Callable,
        name: str = "policy",
        env_id: str = "HopRover-v0",
        env_kwargs: dict | None = None,
    ):
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
    """The inverse of the torque task's action map (tasks/torque.py `torque_to_action`,
    beside the map itself; linear unless the env config says otherwise), clipped to
    [-1, 1]."""
    return _torque_to_action(torque, params, config)


class TorchPolicy:
    """A torch module saved with ``torch.export`` (a .pt2 file) that maps raw observations
    (N, obs_dim) float32 to actions (N, action_dim), with everything it needs inside it.
    The file's extra file ``meta.json`` says what it acts in: ``env_id``, ``env_kwargs``
    (e.g. its control period) and how it was made. Deterministic; keeps no state."""

    META = "meta.json"

    def __init__(self, module, meta: dict, name: str = "torch"):
        self.module, self.meta, self.name = module, dict(meta), name
        self.env_id = self.meta.get("env_id", "HopRover-v0")
        self.env_kwargs = dict(self.meta.get("env_kwargs", {}))

    @classmethod
    def load(cls, path, name: str | None = None) -> TorchPolicy:
        """The policy in a .pt2 file. FileNotFoundError if it is missing, ValueError if
        it is not an exported module with hoprover's metadata."""
        import torch

        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"policy file not found: {path}")
        extra = {cls.META: ""}
        try:
            program = torch.export.load(str(path), extra_files=extra)
        except Exception as exc:  # a corrupt or foreign file: say which
            raise ValueError(
                f"{path} is not a module saved with torch.export ({type(exc).__name__}: {exc})"
            ) from None
        if not extra[cls.META]:
            raise ValueError(
                f"{path} carries no {cls.META}: save it with TorchPolicy.save (env_id, env_kwargs)"
            )
        return cls(program.module(), json.loads(extra[cls.META]), name or path.stem)

    @staticmethod
    def save(module, example_obs, path, meta: dict) -> None:
        """Export `module` (raw observations -> actions) for any batch size, with `meta`
        (at least env_id and env_kwargs), to `path` (.pt2), written atomically."""
        import io

        import torch

        from hoprover_env.util.files import atomic_write

        for key in ("env_id", "env_kwargs"):
            if key not in meta:
                raise ValueError(f"TorchPolicy.save: meta needs {key!r}")
        program = torch.export.export(
            module, (example_obs,), dynamic_shapes=({0: torch.export.Dim("batch")},)
        )
        for node in program.graph.nodes:
            # the source lines that traced each node: paths of the machine it was made on
            node.meta.pop("stack_trace", None)
        buf = io.BytesIO()
        torch.export.save(program, buf, extra_files={TorchPolicy.META: json.dumps(meta)})
        atomic_write(Path(path), buf.getvalue())

    def reset(self, n: int, first_episode: int = 0) -> None:
        """Start `n` episodes (the module keeps no per-episode state)."""

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Deterministic actions for raw observations."""
        import torch

        with torch.no_grad():
            out = self.module(torch.as_tensor(np.asarray(obs), dtype=torch.float32))
        return out.numpy().astype(np.float64)
