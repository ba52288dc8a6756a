"""A table of best-known plans from HopRover-v0's start state, made alike between
neighbouring targets, and a network cloned from it: a learned policy within 5 % of the
best-known plans.

Why a table: mpc's demonstrations are not one function of the state. From nearby targets
its search returns plans of nearly equal cost but of another kind (launch window, flight
gains, correction windows), and a clone fits their average (docs/studies/plan-clone.md,
section 1; docs/studies/imitation-of-mpc.md). Here each target of a dense grid gets its
plan once, offline, and the plans are then made alike wherever that costs (almost)
nothing:

1. a search per target (`planning.search`, mpc's budget) on a grid of step `step` m
   from the band's edge to 1 m on each side, then `passes` continuation passes that
   search each target again from its two neighbours' plans;
2. every plan flies the same flight gains (the median of the long hops), with its launch
   torque, launch window, landing attitude and corrections searched again locally
   (CMA-ES from the plan) and kept where its TTRTP stays within `keep` of the plan's;
3. a launch held until liftoff, then no correction windows, each kept per target where
   TTRTP stays within `tol`;
4. the short hops on the negative side flown as the mirror images of the positive
   side's where that costs at most `mirror_tol`: the search alternates between two kinds
   of short hop (a push, a gentle tip) three times on one side and once on the other,
   and the physics is symmetric (mirrored long hops take the same time).

What is left is a smooth family on long hops (the launch torque and the landing attitude
change smoothly with the target; one flight law) and two kinds of short hop.
`PlanTableTeacher` flies a table plan as the search flew it (mpc's plan controller), from
the start and again, at once, from any rest state off target (the start shifted in x);
other states keep the plan until its predicted TTRTP has passed, then mpc replans. So its
labels are one function of the state and the target; `collect` records it with DART
noise or shadowing a learner (DAgger), and `python -m research.plan_clone.clone_study fit` fits the
network. `pipeline` (research/plan_clone/pipeline.py) runs the whole recipe from one config.

    python -m research.plan_clone.plan_table build --out runs/plan_table/table.npz
    python -m research.plan_clone.plan_table edge --table runs/plan_table/table.npz \\
        --out runs/plan_table/table_edge.npz \\
        --offsets 0.1002 0.1004 0.1006 0.1008 0.101 0.1012
    python -m research.plan_clone.plan_table judge --table runs/plan_table/table.npz   # as an agent
    python -m research.plan_clone.plan_table collect --table runs/plan_table/table.npz \\
        --out runs/plan_table/demo_1.npz --noise 0 --seed 1
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from hoprover_env import core
from hoprover_env.agents.mpc import MPCPolicy
from hoprover_env.agents.planning import (
    CONTROL_DT,
    Problem,
    evaluate,
    normal_sampler,
    plans_from_points,
    search,
)
from hoprover_env.core.params import RoverParams
from hoprover_env.util.files import write_npz
from research.plan_clone.clone_study import BINS

# m: a target nearer than this to the start (the rover's half-width plus the band's) is
# in the band at t = 0
BAND_EDGE = RoverParams().half_width + RoverParams().band_half_width
LONG_HOP = BINS[-1][0]  # m: beyond, one long hop
# `build`'s settings (module docstring), also the defaults of the pipeline's `table`
TABLE_DEFAULTS = {
    "step": 0.003,
    "budget": 3000,
    "passes": 3,
    "local_budget": 300,
    "keep": 0.005,
    "tol": 0.001,
    "mirror_tol": 0.03,
}
# m: nearer than the default grid's first target (just beyond the band's edge, where the
# nudge's time rises steeply; `refine_edge`), the teacher flies the next row out
ROUND_OUT = BAND_EDGE + TABLE_DEFAULTS["step"] / 2
KP, KD = 2, 3  # the flight gains' coordinates in the search space
LAUNCH_WINDOW = 1  # the launch window's coordinate (1: the longest, 20 s)
CORRECTION_LENGTHS = (9, 6)  # the correction windows' duration coordinates
SIGNED = [4, 7, 10]  # landing attitude and correction torques: [0, 1] maps to [-a, a]


def start_state():
    """(state row, parameters) of HopRover-v0's start: at rest on a face at x = 0."""
    from hoprover_env.envs.vector_env import HopRoverVectorEnv

    venv = HopRoverVectorEnv(1, control_dt=0.5)
    venv.reset(seed=0, options={"target_x": np.array([0.5])})
    return np.array(venv.S[0, : core.S_T]), venv.params[0]


def grid(step: float) -> np.ndarray:
    """Targets from the band's edge to 1 m on both sides, `step` m apart."""
    pos = np.arange(BAND_EDGE + step / 2, 1.0 + 1e-9, step)
    return np.concatenate([-pos[::-1], pos])


def _problems(targets, start, params):
    return [Problem(state=start, target=float(x), params=params) for x in targets]


def sweep(step: float, budget: int, passes: int, log=print) -> dict:
    """Step 1: the best plan found per grid target, then continuation passes."""
    start, params = start_state()
    targets = grid(step)
    probs = _problems(targets, start, params)
    n = len(probs)
    t0 = time.perf_counter()
    res = search(probs, budget=budget, seed=list(range(1, n + 1)))
    u, ttrtp = res.u.copy(), res.ttrtp.copy()
    log(
        f"searched {n} targets in {time.perf_counter() - t0:.0f} s "
        f"({int(np.isnan(ttrtp).sum())} without a plan)"
    )
    for p in range(passes):
        improved = 0
        for shift in (1, -1):  # warm from the neighbour on one side, then the other
            r = search(
                probs,
                budget=max(budget // 6, 200),
                starts=1,
                sigma=0.03,
                warm=np.roll(u, shift, axis=0),
                seed=[10000 * (p + 1) + shift + i for i in range(n)],
            )
            better = np.nan_to_num(r.ttrtp, nan=np.inf) < np.nan_to_num(ttrtp, nan=np.inf)
            u[better], ttrtp[better] = r.u[better], r.ttrtp[better]
            improved += int(better.sum())
        log(f"continuation pass {p + 1}: {improved} plans improved")
    return {"targets": targets, "u": u, "ttrtp": ttrtp, "start": start}


def _local_search(probs, u, cost, ttrtp, free, budget, seed=1000):
    """CMA-ES per problem over the coordinates `free` only, from the rows of `u`; every
    population of every problem in one batch. Returns improved (u, cost, ttrtp)."""
    import cma

    u, cost, ttrtp = u.copy(), cost.copy(), ttrtp.copy()
    es = [
        cma.CMAEvolutionStrategy(
            list(u[i, free]),
            0.02,
            {
                "bounds": [0.0, 1.0],
                "popsize": 10,
                "seed": math.nan,
                "randn": normal_sampler(seed + i),
                "maxfevals": budget,
                "verbose": -9,
                "tolfun": 1e-5,
                "tolx": 1e-7,
            },
        )
        for i in range(len(probs))
    ]
    alive = list(range(len(probs)))
    while alive:
        asks = {i: np.array(es[i].ask()) for i in alive}
        which = np.concatenate([np.full(len(asks[i]), i) for i in alive])
        cand = u[which].copy()
        cand[:, free] = np.concatenate([asks[i] for i in alive])
        c, t = evaluate(probs, which, cand)
        at, nxt = 0, []
        for i in alive:
            m = len(asks[i])
            k = at + int(np.argmin(c[at : at + m]))
            if c[k] < cost[i]:
                cost[i], ttrtp[i], u[i] = c[k], t[k], cand[k]
            es[i].tell(list(asks[i]), list(c[at : at + m]))
            at += m
            if not es[i].stop():
                nxt.append(i)
        alive = nxt
    return u, cost, ttrtp


def make_alike(
    table: dict, local_budget: int, keep: float, tol: float, mirror_tol: float = 0.03, log=print
) -> dict:
    """Steps 2 to 4 (module docstring)."""
    start, params = start_state()
    targets, u0, t0 = table["targets"], table["u"], table["ttrtp"]
    probs = _problems(targets, start, params)
    n = len(probs)
    long_hop = np.abs(targets) > LONG_HOP
    gains = np.median(u0[long_hop][:, [KP, KD]], axis=0)
    u = u0.copy()
    u[:, [KP, KD]] = gains
    cost, ttrtp = evaluate(probs, np.arange(n), u)
    free = [k for k in range(u.shape[1]) if k not in (KP, KD)]
    u, cost, ttrtp = _local_search(probs, u, cost, ttrtp, free, local_budget)
    kept = np.isfinite(ttrtp) & (ttrtp <= t0 * (1 + keep))
    u = np.where(kept[:, None], u, u0)
    ttrtp = np.where(kept, ttrtp, t0)
    log(
        f"common flight gains: kept for {kept.sum()}/{n} targets ({kept[long_hop].sum()}/"
        f"{long_hop.sum()} long hops)"
    )

    def simplify(label, change):
        nonlocal u, ttrtp
        v = u.copy()
        change(v)
        _, tv = evaluate(probs, np.arange(n), v)
        ok = np.isfinite(tv) & (tv <= ttrtp * (1 + tol))
        u[ok], ttrtp[ok] = v[ok], tv[ok]
        log(f"{label}: kept for {ok.sum()}/{n} targets")

    simplify(
        "launch held until liftoff", lambda v: v.__setitem__((slice(None), LAUNCH_WINDOW), 1.0)
    )
    for k in CORRECTION_LENGTHS:
        simplify(
            f"no correction window (coordinate {k})",
            lambda v, k=k: v.__setitem__((slice(None), k), 0.0),
        )
    out = mirror_short_hops({**table, "u": u, "ttrtp": ttrtp}, mirror_tol, log, probs)
    r = out["ttrtp"] / t0
    log(f"TTRTP against step 1's plans: median {np.median(r):.4f}, worst {r.max():.4f}")
    return out


def mirrored(u: np.ndarray) -> np.ndarray:
    """Plans (rows of search-space points) for the opposite target: the signed
    coordinates flip about the middle of their range."""
    mirror = np.array(u, dtype=float)
    mirror[:, SIGNED] = 1.0 - mirror[:, SIGNED]
    return mirror


def mirror_short_hops(table: dict, mirror_tol: float, log=print, probs=None) -> dict:
    """Step 4 (module docstring). The grid is symmetric: row k mirrors row n-1-k.
    `probs`: the table's planning problems, if the caller has them already."""
    targets, u, ttrtp = table["targets"], table["u"].copy(), table["ttrtp"].copy()
    if probs is None:
        probs = _problems(targets, *start_state())
    mirror = mirrored(u[::-1])
    _, tm = evaluate(probs, np.arange(len(targets)), mirror)
    short = (targets < 0) & (np.abs(targets) <= LONG_HOP)
    ok = short & np.isfinite(tm) & (tm <= ttrtp * (1 + mirror_tol))
    u[ok], ttrtp[ok] = mirror[ok], tm[ok]
    log(f"negative short hops mirrored: {ok.sum()}/{short.sum()}")
    return {**table, "u": u, "ttrtp": ttrtp}


def refine_edge(table: dict, offsets, budget: int = 3000, log=print) -> dict:
    """The table with rows added at `offsets` (m, beyond the band's edge and nearer than
    the grid's first target), on both sides: just beyond the edge the best nudge's time
    rises steeply (8.1 s at 0.1002 m, 12.5 s at the grid's 0.1015 m; level-v1's target
    at -0.10044 m has a reference of 9.0 s, which the grid's plan takes 1.39 times).
    Each offset is searched afresh and from the plan of the grid's first target; the
    better is kept, and its mirror image flies the negative side (mirrored plans take
    the same time, tests/research/test_plan_table.py)."""
    start, params = start_state()
    xs = np.asarray(offsets, dtype=float)
    probs = _problems(xs, start, params)
    n = len(xs)
    first = table["u"][int(np.searchsorted(table["targets"], 0.0))]
    a = search(probs, budget=budget, seed=list(range(1, n + 1)))
    b = search(
        probs,
        budget=max(budget // 6, 200),
        starts=1,
        sigma=0.03,
        warm=np.tile(first, (n, 1)),
        seed=list(range(n + 1, 2 * n + 1)),
    )
    ta, tb = np.nan_to_num(a.ttrtp, nan=np.inf), np.nan_to_num(b.ttrtp, nan=np.inf)
    u, t = np.where((ta <= tb)[:, None], a.u, b.u), np.fmin(ta, tb)
    mirror = mirrored(u)
    targets = np.concatenate([table["targets"], xs, -xs])
    order = np.argsort(targets)
    log(f"edge rows: {np.round(xs, 5).tolist()} take {np.round(t, 2).tolist()} s")
    return {
        **table,
        "targets": targets[order],
        "u": np.concatenate([table["u"], u, mirror])[order],
        "ttrtp": np.concatenate([table["ttrtp"], t, t])[order],
    }


class PlanTableTeacher(MPCPolicy):
    """mpc whose plans from rest come from a table (`build`): the plan of the nearest
    grid target (of the next one out nearer than `ROUND_OUT`), or with `interpolate` the
    linear blend of its two neighbours' points in the search space. A rover in the band
    at the start gets no plan (zero torque).

    The table holds plans from the start state, but on the table's ground a rover at
    rest on a face anywhere is that state shifted in x (`rest_offset`): the kernel puts
    every double contact at theta = omega = vy = 0 and y = h (`set_double_contact`), so
    a quarter turn of the cube never shows, and the plans are relative to their start
    time t0 (`plans_from_points`; the physics does not depend on t). So at every control
    instant at which the rover is at rest (state F) out of the band, the teacher flies,
    from that instant, the table plan for the remaining offset: at rest with zero torque
    it never moves again, so waiting (mpc's GROUND_WAIT is for a rover on the ground that
    has not come to rest) would only add time, and the label at such a state is the one
    at t = 0 for the same offset (a launch), even while an earlier plan's windows run (a
    learner that rocks back onto its face): on every grid target the teacher alone
    takes the table's time to 1e-12 either way. Any other state (in flight, rocking,
    sliding) keeps the current plan until its predicted TTRTP plus `grace` s has passed,
    then mpc replans (with `budget` candidates) as it would; so does a rest state the
    table does not cover (beyond its farthest target, or too late in the episode)."""

    # counted in run_episodes' worker processes too (MPCPolicy.COUNTERS)
    COUNTERS = MPCPolicy.COUNTERS + ("table_plans",)

    def __init__(self, table: dict, interpolate: bool = False, grace: float = 5.0, **kw):
        super().__init__(**kw)
        self.targets, self.points, self.ttrtp = table["targets"], table["u"], table["ttrtp"]
        self.start = np.asarray(table["start"])
        self.ground = start_state()[1]  # the ground and rover the table was searched on
        self.interpolate, self.grace = interpolate, grace
        self.name = "plan-table"
        self.table_plans = 0
        self.until = []
        self.episode = ([], 600.0)  # (params, episode time) of the env `act` last saw
        # the nudge at the band's edge, flown as state feedback (research/plan_clone/nudge.py)
        from research.plan_clone.nudge import family_of

        self.nudge = family_of(table)
        self.nudged = np.zeros(0, dtype=bool)  # rows of the last `act` the nudge labelled

    def reset(self, n: int, first_episode: int = 0) -> None:
        super().reset(n, first_episode)
        self.until = [-math.inf] * n

    def point(self, target: float) -> np.ndarray:
        side = np.sign(self.targets) == np.sign(target)
        xs, us = self.targets[side], self.points[side]
        if abs(target) < ROUND_OUT:
            # a nudge that falls a fraction of a millimetre short misses and must be
            # tried again; one that goes a little further still ends in the 10 cm band
            out = np.where(np.abs(xs) >= abs(target), np.abs(xs), np.inf)
            return us[int(np.argmin(out))]
        k = int(np.searchsorted(xs, target))
        if k == 0 or k == len(xs) or not self.interpolate:
            return us[int(np.argmin(np.abs(xs - target)))]
        w = (target - xs[k - 1]) / (xs[k] - xs[k - 1])
        return (1.0 - w) * us[k - 1] + w * us[k]

    def rest_offset(self, s: np.ndarray, params, t_total: float = 600.0):
        """The target's offset from a rover at rest out of the band in `s` (a state row)
        if the table has a plan for it that ends within the episode (`t_total` s), else
        None: the rover must be in the table's start state shifted in x, on its ground."""
        offset = float(s[core.S_XT] - s[core.S_X])
        if (
            int(s[core.S_MODE]) != core.MODE_F
            or s[core.S_INBAND] != 0.0
            or not np.array_equal(s[1 : core.S_T], self.start[1:])
            or params != self.ground
            or abs(offset) <= BAND_EDGE
            or abs(offset) > np.abs(self.targets).max()
        ):
            return None
        end = float(s[core.S_T]) + float(np.interp(offset, self.targets, self.ttrtp))
        return offset if end + self.grace <= t_total else None

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        self.episode = (venv.params, float(venv.config.episode_time))  # for needs_plan
        self.nudged = np.zeros(len(obs), dtype=bool)
        if self.nudge is not None:
            from research.plan_clone.nudge import near_edge

            self.nudged = near_edge(obs, float(self.nudge["offsets"].max())) & np.array(
                [p == self.ground for p in venv.params]
            )
        out = super().act(obs, venv)
        if self.nudged.any():
            from research.plan_clone.nudge import family_actions

            out[self.nudged, 0] = family_actions(obs[self.nudged], self.nudge)
        return out

    def needs_plan(self, i: int, S: np.ndarray) -> bool:
        if i < len(self.nudged) and self.nudged[i]:
            self.plans[i] = None  # the nudge law acts; no plan is searched
            return False
        if self.rest_offset(S, self.episode[0][i], self.episode[1]) is not None:
            return True  # at rest off target: the table's plan (class docstring)
        if float(S[core.S_T]) < self.until[i]:
            return False
        return super().needs_plan(i, S)

    def _replan(self, todo: list, venv, S, params) -> None:
        rest = []
        for i in todo:
            t = float(S[i, core.S_T])
            self.plans[i] = None
            offset = self.rest_offset(S[i], params[i], float(venv.config.episode_time))
            if offset is None:
                if t == 0.0 and np.array_equal(S[i, : core.S_T], self.start):
                    continue  # in the band at the start: nothing to do
                rest.append(i)
                continue
            self.plans[i] = plans_from_points(
                self.point(offset)[None], np.array([np.sign(offset)]), np.array([t]), params[i]
            )[0]
            self.until[i] = t + float(np.interp(offset, self.targets, self.ttrtp)) + self.grace
            self.replanned_aloft[i] = False
            self.table_plans += 1
        if rest:
            super()._replan(rest, venv, S, params)


def build(settings: dict, log=print) -> dict:
    """Steps 1 to 4 with `settings` (the keys of TABLE_DEFAULTS)."""
    return make_alike(
        sweep(settings["step"], settings["budget"], settings["passes"], log),
        settings["local_budget"],
        settings["keep"],
        settings["tol"],
        settings["mirror_tol"],
        log,
    )


def load_table(path) -> dict:
    """A table written by `build` / `edge` (and `python -m research.plan_clone.nudge search`: its
    nudge_* arrays)."""
    with np.load(path) as f:
        return {
            k: f[k]
            for k in f.files
            if k in ("targets", "u", "ttrtp", "start") or k.startswith("nudge_")
        }


def within_cells(targets: np.ndarray, rng) -> np.ndarray:
    """One target drawn uniformly in each row's cell: the targets the teacher flies that
    row's plan for (`PlanTableTeacher.point`: the nearest row on the same side), from the
    midpoints between neighbours, from the band's edge for the innermost rows, and out to
    the row itself for the outermost (beyond it the table has no plan)."""
    x = np.asarray(targets, dtype=float)
    out = np.empty_like(x)
    for side in (x > 0, x < 0):
        order = np.argsort(np.abs(x[side]))
        a = np.abs(x[side])[order]  # the side's rows, nearest first
        mid = (a[:-1] + a[1:]) / 2
        drawn = np.empty_like(a)
        drawn[order] = rng.uniform(np.r_[BAND_EDGE, mid], np.r_[mid, a[-1]])
        out[side] = np.sign(x[side]) * drawn
    return out


def collect_table(
    table: dict,
    noise: float,
    seed: int,
    in_band: int,
    learner=None,
    budget: int = 500,
    cells: bool = False,
    log=print,
):
    """(obs, labels, returns) of the teacher on every grid target plus `in_band` targets
    drawn in the band, with DART noise `noise` or with `learner` driving (DAgger). With
    `cells`, each grid target is replaced by one drawn in its cell (`within_cells`): a
    network that sees only the grid's targets interpolates between neighbouring rows
    whose plans are of different kinds, and between them it flies a mix of both."""
    from hoprover_env.training.warm_start import collect

    teacher = PlanTableTeacher(table, budget=budget)
    rng = np.random.default_rng(seed)
    targets = np.concatenate([table["targets"], rng.uniform(-BAND_EDGE, BAND_EDGE, in_band)])
    if cells:
        targets[: len(table["targets"])] = within_cells(table["targets"], rng)
    return collect(
        teacher,
        {"control_dt": CONTROL_DT},
        len(targets),
        seed,
        0.995,
        batch=360,
        noise=noise,
        executor=learner,
        targets=targets,
        log=log,
    )


def main(argv=None) -> int:
    from research.plan_clone.features import FEATURE_EXTRACTORS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build", help="search the grid and make the plans alike")
    b.add_argument("--out", required=True)
    for key, value in TABLE_DEFAULTS.items():
        b.add_argument(f"--{key.replace('_', '-')}", type=type(value), default=value)
    e = sub.add_parser("edge", help="add rows just beyond the band's edge (refine_edge)")
    e.add_argument("--table", required=True)
    e.add_argument("--out", required=True)
    e.add_argument("--offsets", type=float, nargs="+", required=True)
    e.add_argument("--budget", type=int, default=TABLE_DEFAULTS["budget"])
    j = sub.add_parser("judge", help="the table itself as an agent, on the suite")
    j.add_argument("--table", required=True)
    j.add_argument("--interpolate", action="store_true")
    c = sub.add_parser("collect", help="the teacher's demonstrations or DAgger labels")
    c.add_argument("--table", required=True)
    c.add_argument("--out", required=True)
    c.add_argument("--noise", type=float, default=0.0)
    c.add_argument("--seed", type=int, required=True)
    c.add_argument("--in-band", type=int, default=120)
    c.add_argument("--learner", default=None, help="a clone saved by clone_study fit --save")
    c.add_argument("--activation", default="relu", help="the learner's activation")
    c.add_argument(
        "--features",
        default=None,
        choices=sorted(FEATURE_EXTRACTORS),
        help="the learner's input features (research.plan_clone.features)",
    )
    p = sub.add_parser("pipeline", help="table, demonstrations, fits and DAgger rounds")
    p.add_argument("--config", default="research/plan_clone/plan_clone.yaml")
    p.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    log = lambda m: print(m, flush=True)  # noqa: E731
    if args.cmd == "pipeline":
        from research.plan_clone.pipeline import pipeline

        pipeline(args.config, args.out, log)
    elif args.cmd == "build":
        table = build({key: getattr(args, key) for key in TABLE_DEFAULTS}, log)
        write_npz(args.out, **table)
        log(f"{len(table['targets'])} plans -> {args.out}")
    elif args.cmd == "edge":
        table = refine_edge(load_table(args.table), args.offsets, args.budget, log)
        write_npz(args.out, **table)
    elif args.cmd == "judge":
        import json

        from research.plan_clone.clone_study import judge

        teacher = PlanTableTeacher(load_table(args.table), interpolate=args.interpolate)
        log(json.dumps(judge(teacher), indent=1))
    else:
        learner = None
        if args.learner:
            from research.plan_clone.clone_study import load_clone

            learner = load_clone(args.learner, args.activation, features=args.features)
        t0 = time.perf_counter()
        obs, act, ret = collect_table(
            load_table(args.table), args.noise, args.seed, args.in_band, learner, log=log
        )
        write_npz(args.out, obs=obs, act=act, ret=ret)
        log(f"{len(obs)} steps in {time.perf_counter() - t0:.0f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
