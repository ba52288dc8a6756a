"""A nudge at the band's edge as state feedback, for the plan-table teacher.

Just beyond the band's edge (a target 0.1-0.115 m from the rover at rest) the best-known
plans are nudges: a small push, then a brake held for a few seconds, timed by the plan's
clock. A clone cannot copy that timing: the states it must tell apart differ by a
fraction of a milliradian and of a millimetre, and the same state gets "brake" from one
plan and "nothing" from another (docs/studies/plan-clone.md, section 3). So the
teacher flies the nudge as a law of the observed state alone, with three numbers per
offset, chosen by a grid search and made to change smoothly with the offset:

* at rest on a face, out of the band: push toward the target with `push` of T_max;
* pivoting on a corner (states B-E), tilted toward the target and still tipping that
  way: push while the tilt |theta| is below `tilt` [rad], brake with `brake` of T_max
  beyond it;
* anything else: no torque (the rover rocks back and settles; at rest off target the
  law pushes again).

`nudge_actions` is that law on HopRover-v0's observations (the teacher labels with it,
and stored collections are relabelled with it), on the states `near_edge`
(research.plan_clone.gated) picks: nearly still within NUDGE_MAX of the target. `search` flies
a grid of the three numbers for each offset in one vector env; `choose` picks per
offset the point whose worst TTRTP over its grid neighbours (a clone's error: +-1 step
of each number; `margin` steps with the pipeline's `nudge: {margin: k}`) is smallest,
with a penalty on jumps between neighbouring offsets.

One network fitted to everything does not learn the law (its brakes are a few thousand
samples among millions); `fit` fits a network to the law's states alone, and `assemble`
puts it beside a plan-table clone as the nudge branch of a gated network
(research.plan_clone.gated), the bundled `plan_clone`. `gated_rounds` does this within
`python -m research.plan_clone.plan_table pipeline`, with DAgger rounds at the band's edge
(`collect_edge`); by hand:

    python -m research.plan_clone.nudge search --table runs/plan_table/table.npz \\
        --out runs/plan_table/table_nudge.npz
    python -m research.plan_clone.nudge relabel --table runs/plan_table/table_nudge.npz \\
        --data runs/plan_table/demo_*.npz --out-dir runs/plan_table/relabelled
    python -m research.plan_clone.nudge fit --data runs/plan_table/relabelled/*.npz \\
        --save runs/plan_table/nudge_branch.pkl --mirror
    python -m research.plan_clone.nudge assemble --main runs/plan_table \\
        --nudge runs/plan_table/nudge_branch.pkl --out runs/plan_table/plan_clone.pt \\
        --symmetric
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from hoprover_env.core.layout import MODE_B, MODE_E, MODE_F
from hoprover_env.tasks.observation import OBS_DX, OBS_RATE, OBS_SIN, POS_SCALE, RATE_SCALE
from research.plan_clone.gated import NUDGE_MAX, near_edge, observed_mode  # noqa: F401
from research.plan_clone.plan_table import BAND_EDGE

PIVOTS = tuple(range(MODE_B, MODE_E + 1))  # B-E: on one corner
PREFIX = "nudge_"  # a table's arrays of the nudge family
# the grid `search` flies (fractions of T_max, rad, fractions of T_max)
PUSH_GRID = np.arange(0.02, 0.2001, 0.005)
TILT_GRID = np.geomspace(1e-4, 6e-3, 16)
BRAKE_GRID = np.arange(0.0, 0.3001, 0.005)
OFFSETS = (
    0.10005,
    0.1001,
    0.1002,
    0.1003,
    0.1004,
    0.1006,
    0.1008,
    0.101,
    0.1013,
    0.1016,
    0.102,
    0.1025,
    0.103,
    0.1035,
    0.104,
    0.105,
    0.106,
    0.107,
    0.108,
    0.109,
    0.11,
    0.1115,
    0.113,
    0.115,
)


def nudge_actions(obs: np.ndarray, push, tilt, brake) -> np.ndarray:
    """The nudge law's actions (torque / T_max) for observations `obs` (N, 19); `push`,
    `tilt`, `brake` per row (or scalars). Rows in flight, in the band at rest, or
    rocking back get 0."""
    obs = np.asarray(obs, dtype=np.float64)
    offset = -obs[:, OBS_DX] * POS_SCALE  # target minus c.m. [m]
    d = np.where(offset >= 0.0, 1.0, -1.0)
    mode = observed_mode(obs)
    theta = np.arcsin(np.clip(obs[:, OBS_SIN], -1.0, 1.0))
    omega = obs[:, OBS_RATE] * RATE_SCALE
    push, tilt, brake = (
        np.broadcast_to(np.asarray(v, dtype=float), len(obs)) for v in (push, tilt, brake)
    )
    rest = (mode == MODE_F) & (np.abs(offset) > BAND_EDGE)
    tipping = np.isin(mode, PIVOTS) & (theta * d > 0.0) & (omega * d > 0.0)
    a = np.where(rest | (tipping & (np.abs(theta) < tilt)), push, 0.0)
    a = np.where(tipping & (np.abs(theta) >= tilt), -brake, a)
    return a * d


def family_of(table: dict) -> dict | None:
    """The nudge family a table holds (`search`'s output), or None."""
    return {k[len(PREFIX) :]: v for k, v in table.items() if k.startswith(PREFIX)} or None


def with_family(table: dict, family: dict) -> dict:
    """`table` holding `family` (in place of any it had)."""
    return {
        **{k: v for k, v in table.items() if not k.startswith(PREFIX)},
        **{PREFIX + k: v for k, v in family.items()},
    }


def family_actions(obs: np.ndarray, family: dict) -> np.ndarray:
    """The law's actions for observations `obs`, with the family's numbers at each
    row's offset."""
    return nudge_actions(obs, *family_at(family, -obs[:, OBS_DX] * POS_SCALE))


def family_at(family: dict, offset) -> tuple:
    """(push, tilt, brake) at |offset| [m], linear between the family's offsets (the
    nearest end beyond them)."""
    x = np.abs(np.asarray(offset, dtype=float))
    return tuple(np.interp(x, family["offsets"], family[k]) for k in ("push", "tilt", "brake"))


class _GridFlyer:
    """A policy flying the nudge law with per-episode numbers (for `search`)."""

    def __init__(self, push, tilt, brake):
        self.push, self.tilt, self.brake = push, tilt, brake
        self.name, self.env_kwargs, self.first = "nudge-grid", {"control_dt": 0.5}, 0

    def reset(self, n: int, first_episode: int = 0) -> None:
        self.first = first_episode

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        s = slice(self.first, self.first + len(obs))
        return nudge_actions(obs, self.push[s], self.tilt[s], self.brake[s])[:, None]


def search(offsets=None, log=print) -> dict:
    """TTRTP [s] (inf: missed) of every grid point for each offset (default `OFFSETS`),
    from the start."""
    from hoprover_env.evaluation.episodes import run_episodes

    offsets = OFFSETS if offsets is None else offsets
    P, T, B = (a.ravel() for a in np.meshgrid(PUSH_GRID, TILT_GRID, BRAKE_GRID, indexing="ij"))
    out = {}
    for x in offsets:
        t0 = time.perf_counter()
        res = run_episodes(_GridFlyer(P, T, B), np.full(len(P), x), batch=len(P))
        tt = np.array([r.ttrtp if r.success else np.inf for r in res])
        out[x] = tt.reshape(len(PUSH_GRID), len(TILT_GRID), len(BRAKE_GRID))
        log(f"offset {x}: best {tt.min():.2f} s ({time.perf_counter() - t0:.0f} s)")
    return out


def choose(grid: dict, jump_cost: float = 0.02, keep: int = 60, margin: int = 1) -> dict:
    """Per offset the grid point with the smallest worst TTRTP over its neighbours
    (+-`margin` steps of each number), relative to the offset's best; among each
    offset's `keep` best, the path that also pays `jump_cost` per grid step between
    neighbouring offsets (dynamic programming)."""
    from scipy.ndimage import maximum_filter

    xs = sorted(grid)
    cost, cand = [], []
    for x in xs:
        robust = maximum_filter(grid[x], size=2 * margin + 1, mode="nearest")
        order = np.argsort(robust.ravel())[:keep]
        cost.append(robust.ravel()[order] / grid[x].min())
        cand.append(np.array(np.unravel_index(order, robust.shape)).T)
    total, back = cost[0].copy(), []
    for i in range(1, len(xs)):
        jumps = np.abs(cand[i][:, None, :] - cand[i - 1][None, :, :]).sum(axis=2)
        paid = total[None, :] + jump_cost * jumps
        back.append(np.argmin(paid, axis=1))
        total = cost[i] + paid[np.arange(len(cand[i])), back[-1]]
    path = [int(np.argmin(total))]
    for b in reversed(back):
        path.append(int(b[path[-1]]))
    idx = np.array([cand[i][k] for i, k in enumerate(path[::-1])])
    return {
        "offsets": np.array(xs),
        "push": PUSH_GRID[idx[:, 0]],
        "tilt": TILT_GRID[idx[:, 1]],
        "brake": BRAKE_GRID[idx[:, 2]],
        "robust": np.array([cost[i][k] for i, k in enumerate(path[::-1])]),
        "ttrtp": np.array([grid[x][tuple(i)] for x, i in zip(xs, idx)]),
    }


def collect_edge(
    table: dict,
    learner,
    seed: int,
    n: int,
    reach: float,
    noise: float,
    inside: float = 0.0,
    budget: int = 500,
    log=print,
):
    """(obs, labels, returns) of the teacher labelling `learner`'s flights (DAgger) to `n`
    targets uniform in BAND_EDGE - `inside`..`reach` m on alternating sides, with
    N(0, noise^2) on the learner's actions: the states a network meets at the band's
    edge, where its own errors decide where the rover goes next. Starts up to `inside`
    within the band show it where to stay still (the teacher's push begins at the
    edge, and a fit smooths that step into a small push just inside)."""
    from hoprover_env.training.warm_start import collect
    from research.plan_clone.plan_table import CONTROL_DT, PlanTableTeacher

    rng = np.random.default_rng(seed)
    targets = rng.uniform(BAND_EDGE - inside, reach, n) * np.where(np.arange(n) % 2, -1.0, 1.0)
    return collect(
        PlanTableTeacher(table, budget=budget),
        {"control_dt": CONTROL_DT},
        n,
        seed + 7,
        0.995,
        batch=400,
        targets=targets,
        log=log,
        executor=_Noisy(learner, noise, np.random.default_rng(seed + 1)),
    )


class _Noisy:
    """`policy`'s actions plus N(0, noise^2): a DAgger learner that also visits the
    states around its own path."""

    def __init__(self, policy, noise: float, rng):
        self.policy, self.noise, self.rng = policy, float(noise), rng

    def reset(self, n: int) -> None:
        self.policy.reset(n)

    def act(self, obs, venv):
        a = self.policy.act(obs, venv)
        return a + self.noise * self.rng.standard_normal(a.shape) if self.noise else a


def gated_rounds(
    cfg: dict, out, table: dict, data: list, main_pkl: str, settings: dict, shape: dict, log=print
) -> dict:
    """The pipeline's last steps: the nudge branch fitted to the edge states of every
    collection and the gated network of both (research.plan_clone.gated, OUT/plan_clone.pt),
    then each `edge_dagger` round: that network drives at the band's edge
    (`collect_edge`), the main branch is fitted again on everything where the round says
    `refit_main` (warm, `settings` updated by it), and the nudge branch is fitted again.
    The networks that drive the rounds have the ground gate; `flight` (the nudge branch
    also in slow flights), `hold` (zero torque at rest in the band) and `rest` (the gate
    on the ground by the rest offset, research.plan_clone.gated) are the last network's; the
    nudge branch is fitted to the rows of the teacher's own gate either way. Driven with
    the flight gate as well, the rounds gave a worse network
    (docs/studies/plan-clone.md, sections 9 and 10).
    Returns `judge`'s results for the last network."""
    from pathlib import Path

    from hoprover_env.util.files import write_npz
    from research.plan_clone.clone_study import fit, judge, report
    from research.plan_clone.gated import load_any as load_policy

    symmetric, flight = bool(cfg.get("symmetric", False)), bool(cfg.get("flight", False))
    hold, rest = bool(cfg.get("hold", False)), bool(cfg.get("rest", False))
    deadzone = float(cfg.get("deadzone", 0.01))
    net, main_run = out / "plan_clone.pt", str(out)
    edge = list(cfg.get("edge_dagger") or [])
    names = [f"edge_{k + 1}_seed{r['seed']}.npz" for k, r in enumerate(edge)]
    for k in range(len(edge) + 1):
        if k:
            r, path = edge[k - 1], out / names[k - 1]
            if not path.exists():
                obs, act, ret = collect_edge(
                    table,
                    load_policy(str(net)),
                    r["seed"],
                    r.get("n", 1200),
                    r.get("reach", 0.125),
                    r.get("noise", 0.003),
                    r.get("inside", 0.0),
                    log=log,
                )
                write_npz(path, obs=obs, act=act, ret=ret)
            data.append(str(path))
            if r.get("refit_main"):
                refit, main_run = out / f"clone_edge_{k}.pkl", str(out / f"main_edge_{k}")
                if not (refit.exists() and (Path(main_run) / "best_model.zip").exists()):
                    report(
                        fit(
                            data,
                            **shape,
                            save=str(refit),
                            init=main_pkl,
                            export_dir=main_run,
                            log=log,
                            **{**settings, **r["refit_main"]},
                        ),
                        log,
                    )
                main_pkl = str(refit)
        if k < len(edge) and (out / names[k]).exists():
            continue  # the network that drove the next round is not needed
        last = k == len(edge)
        fit_branch(
            data,
            save=str(out / "nudge_branch.pkl"),
            mirror=symmetric,
            flight=flight and last,
            log=log,
        )
        assemble(
            main_run,
            str(out / "nudge_branch.pkl"),
            str(net),
            deadzone=deadzone,
            symmetric=symmetric,
            flight=flight and last,
            hold=hold and last,
            rest=rest and last,
        )
        log(f"gated network after {k} edge rounds -> {net}")
    res = judge(load_policy(str(net)))
    log("gated network (main branch + nudge branch):")
    report(res, log)
    return res


def fit_branch(
    data,
    epochs: int = 15,
    lr: float = 1e-3,
    lr_end: float = 1e-5,
    save=None,
    mirror: bool = False,
    flight: bool = False,
    log=print,
):
    """The nudge branch: configs/ppo_mpc.yaml's actor (ReLU, `features.micro` inputs)
    fitted from scratch to the rows of the collections `data` that `near_edge` picks
    (labelled by the nudge law: relabel older collections with `relabel`); with
    `mirror`, each collection's rows also as their mirror images (observation mirrored,
    action negated: level ground's symmetry, for a symmetric network); with `flight`,
    also the slow flights there (`near_edge(flight=True)`, the gate of a network
    assembled with `flight`), labelled by the teacher as collected. Returns the
    clone as a policy; `save` writes its weights and statistics as `clone_study fit
    --save` does."""
    from hoprover_env.tasks.observation import mirror as mirrored
    from hoprover_env.training.warm_start import clone
    from research.plan_clone.clone_study import _model, _policy, save_clone

    parts = []
    for p in data:
        with np.load(p) as d:
            m = near_edge(d["obs"], flight=flight)
            o, a, r = d["obs"][m], d["act"][m], d["ret"][m]
        if mirror:
            o, a, r = (
                np.concatenate([o, mirrored(o)]),
                np.concatenate([a, -a]),
                np.concatenate([r, r]),
            )
        parts.append((o, a, r))
    obs, act, ret = (np.concatenate([q[k] for q in parts]) for k in range(3))
    if not len(obs):
        raise ValueError(f"no sample of {list(data)} is near the band's edge (near_edge)")
    log(f"{len(obs)} samples near the edge from {len(data)} collections")
    cfg, venv, model = _model("linear", None, "relu", "micro")
    clone(
        model,
        venv,
        obs,
        act,
        ret,
        epochs=epochs,
        batch_size=1024,
        learning_rate=lr,
        learning_rate_end=lr_end,
        value_epochs=0,
        seed=0,
        log=log,
    )
    if save:
        save_clone(save, model, venv)
    return _policy(cfg, venv, model, "nudge-branch")


def relabel(table: dict, obs: np.ndarray, act: np.ndarray) -> np.ndarray:
    """`act` with the rows the table's nudge law covers labelled by it."""
    family = family_of(table)
    m = near_edge(obs, float(family["offsets"].max()))
    out = np.array(act, dtype=np.float64, copy=True)
    out[m, 0] = family_actions(obs[m], family)
    return out


def assemble(
    main_run: str,
    nudge_pkl: str,
    out: str,
    deadzone: float = 0.01,
    symmetric: bool = False,
    flight: bool = False,
    hold: bool = False,
    rest: bool = False,
) -> None:
    """The gated network (research.plan_clone.gated) of a main clone (a run directory) and a
    nudge branch (`fit_branch`'s pickle), saved as `out` (.pt and .json); `symmetric`,
    `flight`, `hold`, `rest`: GatedNet's."""
    from hoprover_env.agents.policies import load_policy
    from research.plan_clone import gated
    from research.plan_clone.clone_study import load_clone

    net = gated.GatedNet(
        gated.Branch.from_sb3(load_policy(main_run)),
        gated.Branch.from_sb3(load_clone(nudge_pkl, "relu", features="micro")),
        deadzone=deadzone,
        symmetric=symmetric,
        flight=flight,
        hold=hold,
        rest=rest,
    )
    gated.save(net, out, {"made_from": {"main": str(main_run), "nudge": str(nudge_pkl)}})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("search", help="search the nudge family and add it to a table")
    s.add_argument("--table", required=True)
    s.add_argument("--out", required=True)
    r = sub.add_parser("relabel", help="label a collection's edge states by the law")
    r.add_argument("--table", required=True, help="a table with a nudge family")
    r.add_argument("--data", nargs="+", required=True)
    r.add_argument("--out-dir", required=True)
    f = sub.add_parser("fit", help="fit the nudge branch to the edge states of collections")
    f.add_argument("--data", nargs="+", required=True)
    f.add_argument("--epochs", type=int, default=15)
    f.add_argument(
        "--mirror",
        action="store_true",
        help="also fit each edge state's mirror image (for assemble --symmetric)",
    )
    f.add_argument(
        "--flight",
        action="store_true",
        help="also the slow flights near the target (for assemble --flight)",
    )
    f.add_argument("--save", required=True)
    g = sub.add_parser("assemble", help="main clone + nudge branch -> a gated network")
    g.add_argument("--main", required=True, help="the main clone's run directory")
    g.add_argument("--nudge", required=True, help="fit's pickle")
    g.add_argument("--out", required=True, help="the network's .pt")
    g.add_argument("--deadzone", type=float, default=0.01)
    g.add_argument(
        "--symmetric",
        action="store_true",
        help="each branch as the odd part of its fit under the mirror x -> -x",
    )
    g.add_argument(
        "--flight",
        action="store_true",
        help="the nudge branch also acts in slow flights near the target",
    )
    g.add_argument(
        "--hold",
        action="store_true",
        help="zero torque at rest on a face with a corner in the band",
    )
    g.add_argument(
        "--rest",
        action="store_true",
        help="gate on the ground by the rest offset (the corner stood on)",
    )
    args = ap.parse_args(argv)
    from pathlib import Path

    from hoprover_env.util.files import write_npz
    from research.plan_clone.plan_table import load_table

    log = lambda m: print(m, flush=True)  # noqa: E731
    if args.cmd == "relabel":
        table = load_table(args.table)
        for p in args.data:
            with np.load(p) as d:
                obs, act, ret = d["obs"], d["act"], d["ret"]
            out = Path(args.out_dir) / Path(p).name
            write_npz(out, obs=obs, act=relabel(table, obs, act), ret=ret)
            log(f"{p} -> {out}")
        return 0
    if args.cmd == "fit":
        fit_branch(
            args.data, args.epochs, save=args.save, mirror=args.mirror, flight=args.flight, log=log
        )
        return 0
    if args.cmd == "assemble":
        assemble(
            args.main,
            args.nudge,
            args.out,
            args.deadzone,
            args.symmetric,
            args.flight,
            args.hold,
            args.rest,
        )
        return 0
    fam = choose(search(log=log))
    for row in zip(*(fam[k] for k in ("offsets", "push", "tilt", "brake", "ttrtp", "robust"))):
        log(
            "offset {:.5f}: push {:.3f}, tilt {:.5f} rad, brake {:.3f}; {:.2f} s "
            "(worst of neighbours {:.3f}x the best)".format(*row)
        )
    write_npz(args.out, **with_family(load_table(args.table), fam))
    return 0


if __name__ == "__main__":
    sys.exit(main())
