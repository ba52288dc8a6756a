"""The mission task decided hop by hop: a learned hop policy that acts on the estimate.

HopRoverMission-v0 hides the state: a torque policy sees noisy attitude and rate, and its
position only from fixes at rest (tasks/mission.py). PPO on that observation, even with
an 8-reading history, learned nothing useful (docs/studies/mission.md): the
launch is open loop, with no landing point or velocity to close it on. This module splits
the problem as a flight team would:

* **Memory**: `hoprover_env.agents.estimation.MissionEstimator` filters the readings into an
  estimate (attitude and bias with covariance, contact state, slope, last fix), and
  `LearnedHopper` remembers its own last hop: the action it took and where it landed.
* **Flight**: the scripted hopper's controller (`ScriptedHopper`) holds the launch
  torque until lift-off, holds the attitude in the air and lets the rover come to rest.
* **Decision**: at rest outside the band, a network maps `features` (the distance to
  go from the fix, the slope estimate, the time, and the last hop's action and outcome)
  to a hop action in [-1, 1], turned into a launch torque by HopRoverHop-v0's map
  (tasks/hop.py `hop_torque`). From the last hop's outcome it can correct for the
  unknown ground and the actuator's scale error, which it never observes.

`MissionHopEnv` is the same loop seen from the decisions (a Gymnasium env, one step per
hop, the mission env's reward summed over the hop): what `research/train_mission.py`
trains PPO on. `MissionHopPolicy` runs a trained network in HopRoverMission-v0 through
`ControllerPolicy`, as `evaluate.py --env HopRoverMission-v0 --policy mission` does.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from hoprover_env.agents.estimation import MissionEstimator
from hoprover_env.agents.scripted import ScriptedHopper
from hoprover_env.envs.registry import HopRoverMissionEnv
from hoprover_env.tasks.hop import HopEnvConfig, hop_torque

# the decision's features (module docstring), each scaled to about [-1, 1]
F_TO_GO, F_SLOPE, F_TIME, F_LAST_ACTION, F_LAST_MOVED, F_LAST_TO_GO, F_HOPS = range(7)
N_FEATURES = 7
DIST_SCALE = 1.0  # m
SLOPE_SCALE = 0.2  # rad
MAX_HOPS = 5.0  # the hop count's scale, not a limit


class LearnedHopper(ScriptedHopper):
    """A contest controller whose hops are chosen by `decide(features) -> action`
    ([-1, 1], HopRoverHop-v0's hop map) instead of the scripted hopper's search; the
    launch, flight and landing are the scripted hopper's."""

    def __init__(self, decide, episode_time: float = 600.0, control_dt: float = 0.5, **kw):
        super().__init__(control_dt=control_dt, **kw)
        self.decide = decide
        self.episode_time = episode_time
        self._hop_vector = HopEnvConfig().task_vector()  # the hop map's launch range

    def reset(self):
        super().reset()
        self.last = None  # the last hop: (fix at its launch, action, to go)

    def at_decision(self, pos, posT, state) -> bool:
        """Whether the next call plans a hop: at rest, outside the band, not launching."""
        return (
            state == "F"
            and self.phase != "launch"
            and not self.in_band(float(pos[0]), float(posT[0]))
        )

    def features(self, x0: float, xt: float, t0: float) -> np.ndarray:
        """The decision's inputs at rest at `x0` (the fix) [m] with target `xt` [m] at
        time `t0` [s]."""
        f = np.zeros(N_FEATURES, np.float32)
        f[F_TO_GO] = (xt - x0) / DIST_SCALE
        f[F_SLOPE] = self.params.slope / SLOPE_SCALE
        f[F_TIME] = t0 / self.episode_time
        if self.last is not None:
            x_prev, a_prev, to_go_prev = self.last
            f[F_LAST_ACTION] = a_prev
            f[F_LAST_MOVED] = (x0 - x_prev) / DIST_SCALE
            f[F_LAST_TO_GO] = to_go_prev / DIST_SCALE
        f[F_HOPS] = self.plans / MAX_HOPS
        return np.clip(f, -5.0, 5.0)

    def plan(self, x0, xt, t0, remaining):
        a = float(np.clip(self.decide(self.features(x0, xt, t0)), -1.0, 1.0))
        if not math.isfinite(a):
            raise ValueError(f"the hop policy returned action {a!r}")
        self.last = (x0, a, xt - x0)
        return float(hop_torque(a, self.params.as_array(), self._hop_vector)), None


class MissionHopEnv(gym.Env):
    """HopRoverMission-v0 seen at its hop decisions: one step runs a hop (launch, flight,
    landing, rest) with `LearnedHopper` on the estimate and returns the next decision's
    features and the mission env's reward summed over the hop. The episode ends with
    the mission's. `kwargs` are HopRoverMission-v0's arguments.

    The reward's `gamma` defaults to 1 here: the torque task's shaping discounts per
    control period (0.99), and summed over the hundreds of periods of a hop its
    (gamma - 1) Phi terms pay a rover for every second it spends far from the target,
    more than the hop's progress is worth. With gamma 1 a hop's reward telescopes to
    Phi(after) - Phi(before), less the time cost, plus the success bonus; the learner
    discounts per hop."""

    metadata = {"render_modes": []}

    def __init__(self, **kwargs):
        from hoprover_env.agents.base import torque_to_action

        self.env = HopRoverMissionEnv(**{"gamma": 1.0, **kwargs})
        self.config = self.env.config
        self._to_action = torque_to_action
        self.observation_space = gym.spaces.Box(-5.0, 5.0, (N_FEATURES,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        self._pending = None
        self.hopper = LearnedHopper(
            self._take, episode_time=self.config.episode_time, control_dt=self.config.control_dt
        )
        self.estimator = MissionEstimator(self.config)

    def _take(self, features):
        a, self._pending = self._pending, None
        return a

    def reset(self, *, seed=None, options=None):
        """A new episode, run to its first decision. An episode that needs none (the
        target's band holds the rover from the start: it only waits out the judge) is
        run to its end and the next one drawn from the env's generator in its place;
        with `options` that fix such an episode there is no other, and ValueError says so."""
        super().reset(seed=seed)
        while True:
            obs, info = self.env.reset(seed=seed, options=options)
            seed = None
            self.hopper.reset()
            self.estimator.reset()
            self.estimator.update(obs, self.env.target_x)
            _, terminated, truncated, info = self._run(info)
            if not (terminated or truncated):
                return self._features(), info
            if options:
                raise ValueError(
                    f"the episode of reset options {options} needs no hop "
                    f"(it starts in the target's band): nothing to decide"
                )

    def _inputs(self):
        return self.estimator.controller_inputs(self.env.target_x)

    def _features(self) -> np.ndarray:
        pos, _, _, _, post, t, _ = self._inputs()
        return self.hopper.features(float(pos[0]), float(post[0]), t)

    def _run(self, info):
        """The control loop until the next decision or the episode's end: (reward
        summed, terminated, truncated, info)."""
        total = 0.0
        while True:
            pos, vel, the, omg, post, t, state = inputs = self._inputs()
            if state == "F":  # the hopper reads the ground only to decide
                self.hopper.use_params(self.estimator.estimated_params())
            if self._pending is None and self.hopper.at_decision(pos, post, state):
                return total, False, False, info
            torque = self.hopper(*inputs[:6], self.config.episode_time, state)
            action = self._to_action(torque, self.hopper.params, self.config)
            obs, r, terminated, truncated, info = self.env.step(np.array([action]))
            total += float(r)
            self.estimator.update(obs, self.env.target_x)
            if terminated or truncated:
                return total, terminated, truncated, info

    def step(self, action):
        a = float(np.asarray(action, dtype=np.float64).reshape(-1)[0])
        if not math.isfinite(a):
            raise ValueError(f"action must be finite, got {a!r}")
        self._pending = a
        total, terminated, truncated, info = self._run({})
        self._pending = None
        # The mission's clock is observed (a feature), so running out of time is a
        # terminal state here, as in HopRoverHop-v0 (tasks/hop.py says why: a learner
        # that bootstraps at the time limit values states no decision is taken in).
        return self._features(), total, terminated or truncated, False, info


def load_mission_policy(path, name: str = "mission", control_dt: float | None = None):
    """A hop network saved by research/train_mission.py (an SB3 PPO .zip, with its .json
    beside it) as a `ControllerPolicy` of `LearnedHopper`s: ``act(obs, venv)`` on
    HopRoverMission-v0 (on the estimate) or on any torque task (on the exact state).
    Raises FileNotFoundError for a missing file."""
    import json
    from pathlib import Path

    from stable_baselines3 import PPO

    from hoprover_env.agents.base import ControllerPolicy

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"hop model not found: {path}")
    meta_path = path.with_suffix(".json")
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    if control_dt is None:
        control_dt = float(meta.get("env_kwargs", {}).get("control_dt", 0.5))
    model = PPO.load(str(path), device="cpu")

    def decide(features):
        return float(model.predict(features, deterministic=True)[0][0])

    policy = ControllerPolicy(
        lambda: LearnedHopper(decide, control_dt=control_dt),
        name=name,
        env_kwargs={"control_dt": control_dt},
    )
    policy.env_id = meta.get("env_id", "HopRoverMission-v0")  # the suite it is judged on
    return policy
