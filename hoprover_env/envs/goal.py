"""HopRoverGoal-v1: the torque task (HopRoverRL-v1) as a goal-conditioned env, in the
Gymnasium-Robotics convention, for hindsight experience replay (SB3's HerReplayBuffer).

## Observation space

`Dict` of

| Key | Space | Meaning |
|---|---|---|
| `observation` | Box(float32, (17,)) | HopRoverRL-v1's observation without its goal-relative slots (the judge's clock and the contact point, which is the bottom corner nearer the target), with the c.m. x and the landing point measured from x = 0 instead of the target (slots 0 and 15 here) |
| `achieved_goal` | Box(float32, (1,)) | where the rover is going: the c.m.'s ballistic landing point in flight, its x in contact [m] |
| `desired_goal` | Box(float32, (1,)) | the target x [m] |

So the observation holds nothing of the goal, and a relabelled goal is as valid as the
drawn one.

## Action space

HopRoverRL-v1's: `Box(-1, 1, (1,), float32)`, a torque held for one control period.

## Rewards

    r = r_free + gamma Phi_g(achieved') - Phi_g(achieved) + success_bonus [success(achieved', g)]

* goal-dependent: the distance potential Phi_g(x) = -dist_weight min(|x - g|, dist_cap)
  / 1 m of the achieved goal (HopRoverRL-v1's landing-point shaping, with the c.m. in
  contact where v1 takes the contact point: the same in flight; its shaping term is 0 on
  the step a rover breaks, as in v1) and the success bonus;
* goal-free (`info["goal_free_reward"]`): the attitude potential, the per-decision
  attitude cost, the time cost, the break penalty and the effort, exactly HopRoverRL-v1's.

success(x, g): the rover ends the step at rest upright (state F) with a bottom corner
within the judge's band of g, i.e. |x - g| <= half width + band half-width. The judge's
5 s dwell is left out: it depends on how long the corner stayed near *this* goal, which a
relabelled transition does not know, so the judge's clock potential (`band_weight`) is 0
here and may not be set. A rover at rest stays at rest under any torque below the
tipping torque, so the dwell is what comes after success; the contest's judge still runs
and `info["ttrtp"]` reports it.

`compute_reward`, `compute_terminated` and `compute_truncated` take batches
(achieved_goal (n, 1), desired_goal (n, 1), infos: a dict or an array of dicts) and give
what `step` gives on the same transition: each transition's info holds the previous
achieved goal, the goal-free reward, whether the rover ended at rest or broke, and the
success radius.

## Episode end

Terminated on success (unless `keep_going`) or when the rover breaks (or the kernel
stops on an error, which the base env ends and pays as a break: `info["broken"]` is true
then here); truncated at `episode_time`, HopRoverRL-v1's (bootstrapped), also where the
contest's judge counted its success in that last step. `keep_going=True` pays the bonus at
every step that ends in success and goes on, so that a goal relabelled from a later
state of the episode stays reachable from the states before it.

## Arguments

`keep_going` (False), `render_mode` (the base env's frames) and HopRoverRL-v1's
arguments, but `band_weight` (refused) and `info_level` (always "full" underneath).
"""  # noqa: E501 (Markdown tables, rendered by docs/_ext/envpages.py: a row cannot wrap)

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from hoprover_env.core.layout import MODE_F
from hoprover_env.envs.registry import env_class, task
from hoprover_env.tasks import torque_rl as v1

BASE_ID = "HopRoverRL-v1"
# the slots of v1's observation measured from the target, made absolute; and those that
# only make sense for the drawn target, dropped
_ABSOLUTE = (v1.OBS_DX, v1.OBS_LANDING)
_KEPT = np.array(
    [i for i in range(v1.OBS_DIM) if i not in (v1.OBS_DWELL, v1.OBS_REF, v1.OBS_REF_FAR)]
)
_FREE_TERMS = ("attitude", "time", "penalty", "energy", "attitude_cost")


class HopRoverGoalEnv(gym.Env):
    """HopRoverGoal-v1 (module docstring: spaces, reward, episode end)."""

    # the base env draws the frames: SB3's make_vec_env asks for "rgb_array" by default
    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}

    def __init__(self, keep_going: bool = False, render_mode: str | None = None, **kwargs: Any):
        for name in ("band_weight", "info_level"):
            if name in kwargs:
                raise TypeError(
                    f"HopRoverGoalEnv() got the argument {name!r}, which the goal "
                    f"variant fixes (its module docstring says why)"
                )
        self.keep_going = bool(keep_going)
        kwargs = {**task(BASE_ID).kwargs, **kwargs}  # the id's settings, as gym.make
        self.base = env_class(BASE_ID)(
            band_weight=0.0, info_level="full", render_mode=render_mode, **kwargs
        )
        self.render_mode = render_mode
        cfg = self.base.config
        self.gamma, self.dist_weight, self.dist_cap = cfg.gamma, cfg.dist_weight, cfg.dist_cap
        self.success_bonus = cfg.success_bonus
        low, high = self.base.observation_space.low, self.base.observation_space.high
        low, high = low.copy(), high.copy()
        for i in _ABSOLUTE:  # measured from x = 0: the target range widens them
            low[i] -= max(abs(r) for r in cfg.target_range)
            high[i] += max(abs(r) for r in cfg.target_range)
        far = v1.FAR + max(abs(r) for r in cfg.target_range)
        goal = gym.spaces.Box(-far, far, (1,), np.float32)
        self.observation_space = gym.spaces.Dict(
            {
                "observation": gym.spaces.Box(low[_KEPT], high[_KEPT], dtype=np.float32),
                "achieved_goal": goal,
                "desired_goal": goal,
            }
        )
        self.action_space = self.base.action_space
        self._achieved = 0.0
        self._target = 0.0

    def _observe(self, obs: np.ndarray) -> dict:
        full = obs.astype(np.float32).copy()
        full[list(_ABSOLUTE)] += np.float32(self._target)
        return {
            "observation": full[_KEPT],
            "achieved_goal": np.array([full[v1.OBS_LANDING]], dtype=np.float32),
            "desired_goal": np.array([self._target], dtype=np.float32),
        }

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.base.reset(seed=seed, options=options)
        self._target = float(info["target_x"])
        out = self._observe(obs)
        self._achieved = float(out["achieved_goal"][0])
        return out, info

    def step(self, action):
        obs, _, terminated, truncated, info = self.base.step(action)
        info = dict(info)
        cause = self.base.end_cause()
        if cause == "broken" and not info["broken"]:
            # the kernel stopped on an error: the base env ends it (and pays it) as a break,
            # so its transitions read as broken here too, relabelled or not
            info["broken"] = np.True_
        broken = bool(info["broken"])
        if cause == "success":  # the judge's success, with time left: the goal is not its
            self.base.continue_episode()
            terminated = False
        elif cause == "time":  # the judge's success in the last step: the clock ends it
            terminated, truncated = False, True
        out = self._observe(obs)
        info["previous_achieved_goal"] = self._achieved
        info["goal_free_reward"] = float(sum(info[f"reward_{t}"] for t in _FREE_TERMS))
        info["at_rest"] = int(info["state"]) == MODE_F
        info["goal_radius"] = float(self.base.params.half_width + self.base.params.band_half_width)
        info["truncated"] = bool(truncated)
        self._achieved = float(out["achieved_goal"][0])
        success = bool(self._success(out["achieved_goal"], out["desired_goal"], info)[0])
        info["is_goal_success"] = success
        reward = float(self.compute_reward(out["achieved_goal"], out["desired_goal"], info))
        terminated = broken or (success and not self.keep_going)
        return out, reward, terminated, bool(truncated), info

    # ---- the Gymnasium-Robotics interface: batches, as HER relabels them ------------
    @staticmethod
    def _columns(info, *keys) -> list[np.ndarray]:
        if isinstance(info, dict):
            return [np.asarray([info[k]]) for k in keys]
        return [np.asarray([i[k] for i in info]) for k in keys]

    def _potential(self, x, goal):
        return -self.dist_weight * np.minimum(np.abs(x - goal), self.dist_cap)

    def _success(self, achieved_goal, desired_goal, info) -> np.ndarray:
        at_rest, radius = self._columns(info, "at_rest", "goal_radius")
        gap = np.abs(
            np.asarray(achieved_goal, float)[..., 0] - np.asarray(desired_goal, float)[..., 0]
        )
        return at_rest.astype(bool) & (gap <= radius)

    def compute_reward(self, achieved_goal, desired_goal, info):
        """The reward of transitions that reached `achieved_goal` under the goals
        `desired_goal` (a scalar for a dict `info`, else one per transition)."""
        prev, free, broken = self._columns(
            info, "previous_achieved_goal", "goal_free_reward", "broken"
        )
        x1 = np.asarray(achieved_goal, float)[..., 0]
        g = np.asarray(desired_goal, float)[..., 0]
        shaping = np.where(
            broken.astype(bool), 0.0, self.gamma * self._potential(x1, g) - self._potential(prev, g)
        )
        r = free + shaping + self.success_bonus * self._success(achieved_goal, desired_goal, info)
        return float(r[0]) if isinstance(info, dict) else r

    def compute_terminated(self, achieved_goal, desired_goal, info):
        """Whether those transitions end their episodes: a break, or success (unless
        keep_going)."""
        (broken,) = self._columns(info, "broken")
        done = broken.astype(bool)
        if not self.keep_going:
            done = done | self._success(achieved_goal, desired_goal, info)
        return bool(done[0]) if isinstance(info, dict) else done

    def compute_truncated(self, achieved_goal, desired_goal, info):
        """Whether those transitions hit the time limit (goal-free)."""
        (trunc,) = self._columns(info, "truncated")
        trunc = trunc.astype(bool)
        return bool(trunc[0]) if isinstance(info, dict) else trunc

    def render(self):
        """The base env's frame (render_mode "rgb_array") or window ("human")."""
        return self.base.render()

    def close(self):
        self.base.close()
