"""Hop plans and a search over them, with the simulator itself as the model.

A *plan* is a small vector that a compiled contest controller (`plan_controller`) reads
from ``posT[2:]`` (`simulate_batch(..., controller_args=plans)`), so that one compiled
function flies a whole population of plans in one threaded call:

==========  =====================================================================
slot        meaning
==========  =====================================================================
``t0``      the plan's start [s]: every window below is relative to it
``inertia`` the rover's moment of inertia [kg m^2] (the attitude hold's scale)
``kp, kd``  attitude-hold gains in flight [1/s^2], [1/s]
``theta*``  the attitude held in flight [rad] (0: land flat on both corners)
per window  ``start, duration, torque``: while the rover is not in flight and
            ``start <= t - t0 < start + duration``, the torque is ``torque`` [N m]
==========  =====================================================================

Outside the windows and out of flight the torque is zero: the rover bounces, slides and
stops on its own. The first window is the launch (a torque held from rest until the
rover lifts off), the others correct or brake. This family is wider than the one-hop
plans of the scripted hopper: the launch window, the flight gains, the landing attitude
and up to two more windows are all searched.

`search` finds, for many problems at once (a start state, a target, a ground), the plan
with the smallest TTRTP: a coarse grid over the launch, then independent CMA-ES runs
(the `cma` package) per problem, every population of every problem simulated in one
`simulate_batch` call. On rough ground each candidate is flown over several terrain
seeds and scored by its mean cost (the planner does not know the episode's bumps), or
over the episode's own seed for a clairvoyant search (the suites' references).

The result is a best-known plan within this family and budget, not an optimum.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hoprover_env.core.params import RoverParams
from hoprover_env.jit.compiler import kernel
from hoprover_env.sim.controllers import attitude_hold

FLIGHT = 0  # state code of state A
HEAD = 5  # t0, inertia, kp, kd, theta*
WINDOW = 3  # start, duration, torque
N_WINDOWS = 3  # launch + two corrections
PLAN_SIZE = HEAD + WINDOW * N_WINDOWS
MISS_COST_PER_M = 100.0  # s per metre of final miss, for plans that fail
BROKEN_COST = 200.0  # s added for a rover that breaks


@kernel
def plan_torque(plan, the, omg, t, state_code):
    """The torque [N m] a plan (layout in the module docstring) commands at time `t`
    [s] in contact state `state_code` (0..6 = A..G) with attitude `the` [rad] and rate
    `omg` [rad/s]."""
    if state_code == FLIGHT:
        return attitude_hold(the - plan[4], omg, plan[1], plan[2], plan[3])
    tau = t - plan[0]
    for w in range((len(plan) - HEAD) // WINDOW):
        b = HEAD + WINDOW * w
        if plan[b] <= tau < plan[b] + plan[b + 1]:
            return plan[b + 2]
    return 0.0


@kernel
def plan_controller(pos, vel, the, omg, posT, t, smt, state_code):
    """Contest controller flying the plan in posT[2:] (simulate_batch's controller_args)."""
    return plan_torque(posT[2:], the, omg, t, state_code)


def plan_end(plan: np.ndarray) -> float:
    """The time [s] after which a plan commands nothing but the flight hold."""
    ends = [
        plan[0] + plan[HEAD + WINDOW * w] + plan[HEAD + WINDOW * w + 1]
        for w in range(N_WINDOWS)
        if plan[HEAD + WINDOW * w + 1] > 0.0
    ]
    return max(ends, default=plan[0])


# ---- the search space: points of [0, 1]^D -> plans -------------------------------------
# launch |torque| (as a fraction of the torque limit), launch window, kp, kd, theta*,
# then per correction window: start (relative), duration, signed torque fraction
LOWER = np.array([0.02, 0.5, 0.02, 0.1, -0.3, 0.0, 0.0, -1.0, 0.0, 0.0, -1.0])
UPPER = np.array([1.00, 20.0, 1.0, 3.0, 0.3, 300.0, 20.0, 1.0, 300.0, 20.0, 1.0])
DIM = len(LOWER)
# the centre of the box the search starts from: kp, kd of the scripted hopper, theta* 0,
# no corrections (zero-length windows)
DEFAULT_U = np.array([0.5, 0.3, 0.13, 0.27, 0.5, 0.3, 0.0, 0.5, 0.6, 0.0, 0.5])


def plans_from_points(
    u: np.ndarray, direction: np.ndarray, t0: np.ndarray, params: RoverParams
) -> np.ndarray:
    """Plans (rows, PLAN_SIZE) from points u (rows, DIM) of [0, 1]^DIM: `direction`
    (+1 or -1 per row) is the launch's sign, `t0` each plan's start [s]."""
    v = LOWER + np.clip(u, 0.0, 1.0) * (UPPER - LOWER)
    n = len(v)
    tmax = min(abs(params.torque_min), abs(params.torque_max))
    plans = np.zeros((n, PLAN_SIZE))
    plans[:, 0] = t0
    plans[:, 1] = params.inertia
    plans[:, 2:5] = v[:, 2:5]
    plans[:, HEAD : HEAD + 3] = np.column_stack([np.zeros(n), v[:, 1], direction * v[:, 0] * tmax])
    for w in range(1, N_WINDOWS):
        b, c = HEAD + WINDOW * w, 5 + 3 * (w - 1)
        plans[:, b : b + 3] = np.column_stack([v[:, c], v[:, c + 1], v[:, c + 2] * tmax])
    return plans


@dataclasses.dataclass
class Problem:
    """One planning problem: the rover at rest (or anywhere) in `state` (x, y, theta,
    vx, vy, omega) at time `t0` [s], a target [m], the ground `params`, the episode's end
    `t_total` [s], and the terrain seeds its candidates are flown over (None: smooth
    ground; on rough ground the clairvoyant search passes the episode's own seed)."""

    state: np.ndarray
    target: float
    params: RoverParams
    t0: float = 0.0
    t_total: float = 600.0
    seeds: tuple | None = None

    @property
    def direction(self) -> float:
        return 1.0 if self.target >= self.state[0] else -1.0


def evaluate(
    problems: list[Problem], which: np.ndarray, u: np.ndarray, horizon: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Cost and TTRTP [s, absolute] of candidate points `u` (rows) for the problems
    `problems[which[j]]`, all in one `simulate_batch` call (each candidate flown once per
    terrain seed of its problem; its cost is the mean over them, its TTRTP the worst).
    `horizon` caps each problem's simulated time (default: to the episode's end); a plan
    that does not reach the target within it costs the horizon plus a charge per metre
    of final miss (and for a break)."""
    from hoprover_env.sim.batch import simulate_batch

    which = np.asarray(which, dtype=np.int64)
    n_seeds = [len(p.seeds) if p.seeds else 1 for p in problems]
    reps = np.array([n_seeds[j] for j in which])
    rows = np.repeat(np.arange(len(which)), reps)
    prob = which[rows]
    span = np.array([p.t_total - p.t0 for p in problems])
    cap = span if horizon is None else np.minimum(span, horizon)
    direction = np.array([problems[j].direction for j in prob])
    plans = plans_from_points(u[rows], direction, np.zeros(len(rows)), problems[which[0]].params)
    # the inertia column is per problem (parameters may differ between problems)
    plans[:, 1] = [problems[j].params.inertia for j in prob]
    seeds = None
    if any(p.seeds for p in problems):
        seeds = np.concatenate(
            [np.asarray(problems[j].seeds or (0,), dtype=np.uint64) for j in which]
        )
    params = [problems[j].params for j in prob]
    targets = np.array([problems[j].target for j in prob])
    states = np.array([problems[j].state for j in prob])
    final_x, ttrtp_run = np.empty(len(rows)), np.empty(len(rows))
    success, broken = np.empty(len(rows), bool), np.empty(len(rows), bool)
    # one batch per horizon: each run ends at its own problem's horizon, so a candidate's
    # cost (its miss and break at the horizon) does not depend on what is searched beside it
    for t_end in np.unique(cap[prob]):
        at = np.flatnonzero(cap[prob] == t_end)
        b = simulate_batch(
            plan_controller,
            targets[at],
            t_end=float(t_end),
            control_dt=CONTROL_DT,
            params=[params[k] for k in at],
            initial_states=states[at],
            controller_args=plans[at],
            seed=None if seeds is None else seeds[at],
            record=False,
        )
        final_x[at], ttrtp_run[at] = b.final[:, 0], b.ttrtp
        success[at], broken[at] = b.success, b.broken
    half = np.array([p.half_width + p.band_half_width for p in params])
    miss = np.maximum(np.abs(final_x - targets) - half, 0.0)
    ok = success & (ttrtp_run <= cap[prob])
    run_cost = np.where(ok, ttrtp_run, cap[prob] + MISS_COST_PER_M * miss + BROKEN_COST * broken)
    run_ttrtp = np.where(ok, ttrtp_run, np.inf)
    cost = np.bincount(rows, weights=run_cost, minlength=len(which)) / reps
    worst = np.full(len(which), -np.inf)
    np.maximum.at(worst, rows, run_ttrtp)
    t0 = np.array([problems[j].t0 for j in which])
    ttrtp = np.where(np.isfinite(worst), worst + t0, np.nan)
    return cost, ttrtp


CONTROL_DT = 0.5  # the control period every plan is flown on [s]


@dataclasses.dataclass
class SearchResult:
    """Per problem: the best point of [0, 1]^DIM found, its cost and TTRTP [s]
    (NaN: no plan reached the target), and the candidates simulated."""

    u: np.ndarray
    cost: np.ndarray
    ttrtp: np.ndarray
    evaluations: np.ndarray

    def plan(self, i: int, problem: Problem) -> np.ndarray:
        """The plan vector of problem i, starting at the problem's own t0."""
        p = plans_from_points(
            self.u[i][None], np.array([problem.direction]), np.array([problem.t0]), problem.params
        )[0]
        return p


def launch_grid(n_torque: int, n_window: int) -> np.ndarray:
    """One-window launches: |torque| x window, the other coordinates at DEFAULT_U."""
    tq = np.linspace(0.0, 1.0, n_torque)
    wd = np.linspace(0.0, 0.4, n_window)  # windows 0.5 .. 8.3 s
    grid = np.tile(DEFAULT_U, (n_torque * n_window, 1))
    grid[:, 0] = np.repeat(tq, n_window)
    grid[:, 1] = np.tile(wd, n_torque)
    return grid


def cma_seed(seed, i: int, r: int) -> int:
    """CMA-ES seed of start r of problem i, from one search seed or per-problem seeds."""
    if isinstance(seed, (int, np.integer)):
        return int(seed) * 1000 + 10 * i + r + 1
    return int(seed[i]) * 10 + r + 1


def normal_sampler(seed: int):
    """randn(*shape) from a generator of its own. pycma draws from numpy's global
    generator by default, which every CMA-ES run of a search would share (asked in
    turn), so that a problem's search would depend on the problems searched beside it."""
    rng = np.random.default_rng(seed)
    return lambda *shape: rng.standard_normal(shape)


def search(
    problems: list[Problem],
    budget: int = 4000,
    starts: int = 2,
    popsize: int = 16,
    sigma: float = 0.12,
    grid: tuple = (16, 4),
    seed: int | list = 0,
    warm: np.ndarray | None = None,
    horizon_slack: float = 1.25,
) -> SearchResult:
    """The best plan per problem within `budget` simulated candidates each (a candidate
    flown over k terrain seeds counts once): a launch grid, then `starts` CMA-ES runs
    per problem from its best grid points of distinct launch torques (or from the rows
    of `warm`, points to start from), each population of every problem in one batch.
    Candidates are simulated only up to `horizon_slack` times the best TTRTP found so
    far (plus 20 s): a plan that cannot beat it by then is not worth finishing.
    `seed`: one integer for the whole search, or one per problem (then a problem's
    search does not depend on the others searched beside it)."""
    import cma

    n = len(problems)
    g = launch_grid(*grid)
    which = np.repeat(np.arange(n), len(g))
    cost, ttrtp = evaluate(problems, which, np.tile(g, (n, 1)))
    cost = cost.reshape(n, len(g))
    ttrtp = ttrtp.reshape(n, len(g))
    best_i = np.argmin(cost, axis=1)
    best_u = g[best_i].copy()
    best_c = cost[np.arange(n), best_i].copy()
    best_t = ttrtp[np.arange(n), best_i].copy()
    evals = np.full(n, len(g))
    if warm is not None:
        wc, wt = evaluate(problems, np.arange(n), warm)
        evals += 1
        better = wc < best_c
        best_u[better], best_c[better], best_t[better] = warm[better], wc[better], wt[better]
    each = max((budget - len(g)) // max(starts, 1), popsize)
    strategies = []  # (problem, CMA-ES)
    for i in range(n):
        order = np.argsort(cost[i], kind="stable")
        chosen, seen = [], set()
        if warm is not None:
            chosen.append(warm[i])
        for k in order:
            if len(chosen) >= starts:
                break
            if g[k][0] not in seen:
                seen.add(g[k][0])
                chosen.append(g[k])
        for r, x0 in enumerate(chosen):
            es = cma.CMAEvolutionStrategy(
                list(x0),
                sigma,
                {
                    "bounds": [0.0, 1.0],
                    "popsize": popsize,
                    "seed": math.nan,
                    "randn": normal_sampler(cma_seed(seed, i, r)),
                    "maxfevals": each,
                    "verbose": -9,
                    "tolfun": 1e-4,
                    "tolx": 1e-6,
                },
            )
            strategies.append((i, es))
    while strategies:
        asks = [np.array(es.ask()) for _, es in strategies]
        owners = np.concatenate([np.full(len(a), i) for (i, _), a in zip(strategies, asks)])
        horizon = np.where(
            np.isfinite(best_t), (best_t - [p.t0 for p in problems]) * horizon_slack + 20.0, np.inf
        )
        c, t = evaluate(problems, owners, np.concatenate(asks), horizon)
        at = 0
        alive = []
        for (i, es), a in zip(strategies, asks):
            ci = c[at : at + len(a)]
            ti = t[at : at + len(a)]
            at += len(a)
            evals[i] += len(a)
            k = int(np.argmin(ci))
            if ci[k] < best_c[i]:
                best_c[i], best_u[i], best_t[i] = ci[k], a[k].copy(), ti[k]
            es.tell(list(a), list(ci))
            if not es.stop():
                alive.append((i, es))
        strategies = alive
    return SearchResult(best_u, best_c, best_t, evals)
