"""`mpc`: a planning agent that uses the simulator itself as its model.

In receding horizon: whenever a rover is at rest outside the band with nothing left of
its plan (at the start of an episode, and after each hop that did not end the
episode), the agent searches the hop-plan family of `hoprover_env.planning` from the
rover's current state for the smallest predicted TTRTP (a launch grid, then CMA-ES,
each population simulated in one `simulate_batch` call), and flies that plan: the
launch and correction windows while on the ground, its attitude hold in flight. All the
sub-envs that need a plan at the same control instant are planned in one batch.

What it knows: the exact state, the rover's parameters and the ground's slope and
roughness (privileged information: the simulator is its model). What it does not know:
the bumps of rough ground. There it flies each candidate over `terrain_samples`
terrain seeds of its own and ranks candidates by their mean cost (expected TTRTP, a
plan that misses counted at the horizon plus a charge per metre of miss); it replans
after every landing, so a bump that throws a hop off is corrected by the next plan.

    from hoprover_env.mpc import MPCPolicy
    policy = MPCPolicy()                 # act(obs, venv) on a HopRoverVectorEnv
"""
from __future__ import annotations

import time

import numpy as np

from . import core
from .planning import CONTROL_DT, Problem, plan_end, plan_torque, search

DEFAULT_BUDGET = 3000        # candidates per decision on smooth ground (see BENCHMARKS.md)
DEFAULT_ROUGH_BUDGET = 1500  # on rough ground, each candidate flown over the samples
DEFAULT_TERRAIN_SAMPLES = 4


class MPCPolicy:
    """Receding-horizon planner acting on a batch of sub-envs (``act(obs, venv)``).

    Parameters: `budget` candidate plans simulated per decision on smooth ground,
    `rough_budget` on rough ground (each flown over `terrain_samples` seeds of the
    agent's own, drawn from `seed`); `name` for tables. Statistics: `decisions` (plans
    made) and `planning_seconds` (wall time spent searching).
    """


    def __init__(self, budget: int = DEFAULT_BUDGET, rough_budget: int = DEFAULT_ROUGH_BUDGET,
                 terrain_samples: int = DEFAULT_TERRAIN_SAMPLES, seed: int = 0,
                 name: str = "mpc"):
        if not (isinstance(budget, int) and budget >= 100):
            raise ValueError(f"budget must be an integer >= 100 (candidates per decision), "
                             f"got {budget!r}")
        if not (isinstance(rough_budget, int) and rough_budget >= 100):
            raise ValueError(f"rough_budget must be an integer >= 100, got {rough_budget!r}")
        if not (isinstance(terrain_samples, int) and terrain_samples >= 1):
            raise ValueError(f"terrain_samples must be an integer >= 1, got "
                             f"{terrain_samples!r}")
        self.budget, self.rough_budget = budget, rough_budget
        self.terrain_samples = terrain_samples
        self.seed = seed
        self.name = name
        self.env_kwargs = {"control_dt": CONTROL_DT}
        self.plans: list = []
        self.decisions = 0
        self.planning_seconds = 0.0
        self.rng = np.random.default_rng(seed)

    def reset(self, n: int, first_episode: int = 0) -> None:
        """Start `n` episodes: no plans yet."""
        self.plans = [None] * n
        # the agent's own terrain samples, a stream per batch of episodes
        self.rng = np.random.default_rng([self.seed, first_episode])

    def needs_plan(self, S: np.ndarray) -> bool:
        """At rest, outside the band, with the current plan (if any) run out."""
        return int(S[core.S_MODE]) == core.MODE_F and S[core.S_INBAND] == 0.0

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Actions (N, 1) for the sub-envs of `venv` (a HopRoverVectorEnv)."""
        from hoprover_env.policies import torque_to_action   # TODO: the package's, after the move
        n = len(obs)
        if len(self.plans) != n:
            self.plans = [None] * n
        todo = [i for i in range(n) if self.needs_plan(venv.S[i]) and (
            self.plans[i] is None or venv.S[i][core.S_T] >= plan_end(self.plans[i]))]
        if todo:
            self._replan(todo, venv)
        out = np.zeros((n, 1))
        for i in range(n):
            s = venv.S[i]
            plan = self.plans[i]
            torque = 0.0 if plan is None else plan_torque(
                plan, float(s[core.S_TH]), float(s[core.S_W]), float(s[core.S_T]),
                int(s[core.S_MODE]))
            out[i, 0] = torque_to_action(float(torque), venv.params[i], venv.config)
        return out

    def _replan(self, todo: list, venv) -> None:
        t_start = time.perf_counter()
        smooth, rough = [], []
        for i in todo:
            s = venv.S[i]
            p = venv.params[i]
            seeds = None
            if p.roughness > 0.0:
                seeds = tuple(int(k) for k in self.rng.integers(0, 2**63,
                                                                self.terrain_samples))
            prob = Problem(state=np.array(s[:core.S_T]), target=float(venv.targets[i]),
                           params=p, t0=float(s[core.S_T]),
                           t_total=float(venv.config.episode_time), seeds=seeds)
            (rough if seeds else smooth).append((i, prob))
        for group, budget in ((smooth, self.budget), (rough, self.rough_budget)):
            if not group:
                continue
            problems = [p for _, p in group]
            result = search(problems, budget=budget, seed=self.decisions)
            for k, (i, prob) in enumerate(group):
                # a target out of reach within the episode still gets the plan that
                # ends nearest to it
                self.plans[i] = result.plan(k, prob)
            self.decisions += len(group)
        self.planning_seconds += time.perf_counter() - t_start
