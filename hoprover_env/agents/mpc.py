"""`mpc`: a planning agent that uses the simulator itself as its model.

In receding horizon: whenever a rover is at rest outside the band with nothing left of
its plan (at the start of an episode, and after each hop that did not end the
episode), the agent searches the hop-plan family of `hoprover_env.agents.planning` from the
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

    from hoprover_env.agents.mpc import MPCPolicy
    policy = MPCPolicy()                 # act(obs, venv) on a HopRoverVectorEnv
"""

from __future__ import annotations

import math
import time

import numpy as np

from hoprover_env import core
from hoprover_env.agents.base import torque_to_action
from hoprover_env.agents.estimation import EstimatorBank, hides_state
from hoprover_env.agents.planning import CONTROL_DT, Problem, plan_end, plan_torque, search

DEFAULT_BUDGET = 3000  # candidates per decision on smooth ground (docs/studies/references.md)
DEFAULT_ROUGH_BUDGET = 1500  # on rough ground, each candidate flown over the samples
DEFAULT_TERRAIN_SAMPLES = 4
GROUND_WAIT = 10.0  # s on the ground without coming to rest before replanning


class MPCPolicy:
    """Receding-horizon planner acting on a batch of sub-envs (``act(obs, venv)``).

    Parameters: `budget` candidate plans simulated per decision on smooth ground,
    `rough_budget` on rough ground (each flown over `terrain_samples` seeds of the
    agent's own, drawn from `seed`); `name` for tables; `workers`, the processes
    `run_episodes` (and so the suites and evaluate.py) spreads this agent's episodes
    over (None: one per core, at most one per 8 episodes; 1: all in the calling
    process). An episode plays the same in any batch (`decision_rng`, per-problem search
    seeds), so the spread changes no result. Statistics: `decisions` (plans made) and
    `planning_seconds` (time spent searching, summed over the workers).
    """

    def __init__(
        self,
        budget: int = DEFAULT_BUDGET,
        rough_budget: int = DEFAULT_ROUGH_BUDGET,
        terrain_samples: int = DEFAULT_TERRAIN_SAMPLES,
        seed: int = 0,
        name: str = "mpc",
        workers: int | None = None,
    ):
        if not (isinstance(budget, int) and budget >= 100):
            raise ValueError(
                f"budget must be an integer >= 100 (candidates per decision), got {budget!r}"
            )
        if not (isinstance(rough_budget, int) and rough_budget >= 100):
            raise ValueError(f"rough_budget must be an integer >= 100, got {rough_budget!r}")
        if not (isinstance(terrain_samples, int) and terrain_samples >= 1):
            raise ValueError(f"terrain_samples must be an integer >= 1, got {terrain_samples!r}")
        if workers is not None and not (isinstance(workers, int) and workers >= 1):
            raise ValueError(
                f"workers must be None (one per core) or an integer >= 1, got {workers!r}"
            )
        self.workers = workers
        self.budget, self.rough_budget = budget, rough_budget
        self.terrain_samples = terrain_samples
        self.seed = seed
        self.name = name
        self.env_kwargs = {"control_dt": CONTROL_DT}
        self.plans: list = []
        self.shadowing = False  # set by imitation.collect when a learner drives
        self.estimates = EstimatorBank()
        self.decisions = 0
        self.planning_seconds = 0.0

    # the counters a copy of the agent in a worker process reports back (a subclass that
    # counts more adds its own), so that they count the episodes of every worker
    COUNTERS = ("decisions", "planning_seconds")

    def statistics(self) -> dict:
        """The counters (`COUNTERS`), for `add_statistics` (run_episodes' workers)."""
        return {k: getattr(self, k) for k in self.COUNTERS}

    def add_statistics(self, stats: dict) -> None:
        """Add what a copy of this agent counted in a worker process."""
        for k, v in stats.items():
            setattr(self, k, getattr(self, k) + v)

    def reset(self, n: int, first_episode: int = 0) -> None:
        """Start `n` episodes: no plans yet (and, on a task that hides its state, fresh
        estimators)."""
        self.plans = [None] * n
        self.grounded_since = [0.0] * n
        self.flew = [False] * n
        self.replanned_aloft = [True] * n
        self.estimates = EstimatorBank()
        self.estimates.reset(n)

    def decision_rng(self, state: np.ndarray, target: float) -> np.random.Generator:
        """The random stream of one decision, keyed by the agent's seed and the exact
        state and target it plans from: a plan is a function of what the agent sees, so
        an episode plays the same alone or at any position of any batch."""
        key = np.append(np.asarray(state, dtype=np.float64), float(target))
        return np.random.default_rng([self.seed, *key.view(np.uint64).tolist()])

    def needs_plan(self, i: int, S: np.ndarray) -> bool:
        """Outside the band with the current plan (if any) run out, and at rest or on
        the ground for `GROUND_WAIT` s without a flight: on a slope of rough ground a
        landing can end in small bounces that creep for minutes without coming to rest
        (the suite's terrain episode 50 crept 0.6 m in 380 s); the plan is made from
        wherever the rover is, the simulator starting from that exact state."""
        t = float(S[core.S_T])
        mode = int(S[core.S_MODE])
        if mode == core.MODE_A:
            self.grounded_since[i] = math.inf
        elif self.grounded_since[i] > t:
            self.grounded_since[i] = t
        if self.shadowing and mode == core.MODE_A and not self.replanned_aloft[i]:
            # a learner drives (DAgger): its hop is not the one this plan launched, so the
            # attitude to land in and the corrections after it are planned again from the
            # flight it actually made (once per plan: not at every bounce)
            self.replanned_aloft[i] = True
            return True
        if S[core.S_INBAND] != 0.0 or (self.plans[i] is not None and t < plan_end(self.plans[i])):
            return False
        return mode == core.MODE_F or t - self.grounded_since[i] >= GROUND_WAIT

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Actions (N, 1) for the sub-envs of `venv` (a HopRoverVectorEnv)."""
        n = len(obs)
        if len(self.plans) != n:
            self.reset(n)
        S, params = self._view(obs, venv)
        if hides_state(venv):
            self._end_plans_at_rest(S)
        todo = [i for i in range(n) if self.needs_plan(i, S[i])]
        if todo:
            self._replan(todo, venv, S, params)
        out = np.zeros((n, 1))
        for i in range(n):
            s = S[i]
            plan = self.plans[i]
            torque = (
                0.0
                if plan is None
                else plan_torque(
                    plan,
                    float(s[core.S_TH]),
                    float(s[core.S_W]),
                    float(s[core.S_T]),
                    int(s[core.S_MODE]),
                )
            )
            out[i, 0] = torque_to_action(float(torque), params[i], venv.config)
        return out

    def _end_plans_at_rest(self, S: np.ndarray) -> None:
        """On a task that hides the state and the ground, a plan's later hops assume
        where its first one landed, on ground the agent does not know: at rest after a
        flight (or in the band) the plan is dropped, and the rover replans from the fix
        (or waits out the judge)."""
        for i in range(len(S)):
            mode = int(S[i, core.S_MODE])
            if mode == core.MODE_A:
                self.flew[i] = True
            elif mode == core.MODE_F and (self.flew[i] or S[i, core.S_INBAND] != 0.0):
                self.plans[i] = None
                self.flew[i] = False

    def _view(self, obs: np.ndarray, venv):
        """(state rows, ground per sub-env) the agent plans from: the exact state, or on
        a task that hides it (HopRoverMission-v0) the estimate from the rover's readings
        (hoprover_env.agents.estimation) and the ground it knows of."""
        if not hides_state(venv):
            return venv.S, venv.params
        self.estimates.update(obs, venv)
        return self.estimates.state_rows(venv)

    def _replan(self, todo: list, venv, S, params) -> None:
        t_start = time.perf_counter()
        smooth, rough = [], []
        for i in todo:
            s = S[i]
            p = params[i]
            rng = self.decision_rng(s[: core.S_T + 1], float(venv.targets[i]))
            seeds = None
            if p.roughness > 0.0:
                seeds = tuple(int(k) for k in rng.integers(0, 2**63, self.terrain_samples))
            start = np.array(s[: core.S_T])
            if hides_state(venv):  # from an estimate: plan as from rest at the fix
                start[2:] = 0.0
            prob = Problem(
                state=start,
                target=float(venv.targets[i]),
                params=p,
                t0=float(s[core.S_T]),
                t_total=float(venv.config.episode_time),
                seeds=seeds,
            )
            (rough if seeds else smooth).append((i, prob, int(rng.integers(1, 2**28))))
        for group, budget in ((smooth, self.budget), (rough, self.rough_budget)):
            if not group:
                continue
            problems = [p for _, p, _ in group]
            result = search(problems, budget=budget, seed=[k for _, _, k in group])
            for k, (i, prob, _) in enumerate(group):
                # a target out of reach within the episode still gets the plan that
                # ends nearest to it
                self.plans[i] = result.plan(k, prob)
                self.replanned_aloft[i] = int(S[i, core.S_MODE]) == core.MODE_A
            self.decisions += len(group)
        self.planning_seconds += time.perf_counter() - t_start
