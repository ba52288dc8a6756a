"""Evaluate policies with the contest judge on a fixed, seeded set of random targets.

    python evaluate.py                                   # the four bundled policies, 200 targets
    python evaluate.py --policy scripted --policy runs/ppo1 --episodes 50
    python evaluate.py --targets 0.5,-0.8 --plot figs --video hop.gif
    python evaluate.py --controller my_entry.py:Control  # a 2015 contest entry, unchanged
    python evaluate.py --episodes 100000 --batch 1000 --ray   # episodes as Ray tasks
    python evaluate.py --policy terrain --policy scripted --env HopRoverTerrain-v0
    python evaluate.py --slope 0.2 --roughness 0.1       # every policy on one incline
    python evaluate.py --suite --policy mpc --policy scratch          # the frozen test suite
    python evaluate.py --suite --env HopRoverTerrain-v0 --policy terrain --json t.json

Prints one table (success rate, median and 90th-percentile TTRTP, broken count, mean
wall time per episode) with one row per policy, all on the same targets. With --suite,
the episodes are the frozen test suite of --env (hoprover_env/evaluation/suites.py) and a second
table scores each policy against the suite's best-known references: success, median
regret and mean and IQM normalised score with 95 % bootstrap intervals (rliable); the
per-episode rows gain reference_ttrtp, regret and score. --json/--csv
write the per-episode results atomically; --plot writes the contest sample's nine
trajectory figures and --video an animation of one episode of the first policy.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
import time

import numpy as np

from hoprover_env.agents.policies import load_controller, load_policy
from hoprover_env.envs.registry import ENVS, default_config
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.util.files import atomic_write, write_json


def task_ground(env_id: str | None) -> dict:
    """The ground a task draws per episode, as its config declares it (EnvConfig.ground:
    {} for the contest's flat, smooth ground; a terrain task's slope range and
    roughness [rad])."""
    return {} if env_id is None else default_config(env_id).ground()


def terrain_conditions(args, n: int) -> dict:
    """The ground of each episode ({} for the contest's flat, smooth ground): slopes
    fixed by --slope or, with an --env that draws its slope (HopRoverTerrain-v0),
    held-out draws from its range (seeded by --seed on their own stream, so the targets
    are those of the flat evaluation), and the roughness (--roughness, or the task's)."""
    ground = {}
    drawn = task_ground(args.env)
    if args.slope is not None:
        ground["slope"] = np.full(n, args.slope)
    elif "slope" in drawn:
        ground["slope"] = np.random.default_rng([args.seed, 1]).uniform(*drawn["slope"], n)
    if args.roughness is not None:
        ground["roughness"] = np.full(n, args.roughness)
    elif "roughness" in drawn:
        ground["roughness"] = np.full(n, drawn["roughness"])
    return ground


def parse_args(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n", 2)[2],
    )
    ap.add_argument(
        "--policy",
        action="append",
        default=None,
        help="scratch, hop, bundled, scripted, random, or a model .zip / run "
        "directory (repeat to compare; default: scratch, hop, bundled "
        "and scripted)",
    )
    ap.add_argument(
        "--controller",
        action="append",
        default=[],
        help="a contest controller module.py:Function (repeatable)",
    )
    ap.add_argument("--episodes", type=int, default=200, help="number of targets (default 200)")
    ap.add_argument(
        "--targets",
        type=str,
        default=None,
        help="comma-separated target x values instead of random ones",
    )
    ap.add_argument(
        "--target-range",
        type=float,
        nargs=2,
        default=(-1.0, 1.0),
        metavar=("LOW", "HIGH"),
        help="range of the random targets [m]",
    )
    ap.add_argument("--seed", type=int, default=2015, help="seed of the random targets")
    ap.add_argument(
        "--control-dt",
        type=float,
        default=0.5,
        help="control period of scripted/contest controllers [s]",
    )
    ap.add_argument("--json", type=str, default=None, help="write per-episode results (JSON)")
    ap.add_argument("--csv", type=str, default=None, help="write per-episode results (CSV)")
    ap.add_argument("--plot", type=str, default=None, help="directory for the nine figures")
    ap.add_argument("--video", type=str, default=None, help="GIF or MP4 of an episode")
    ap.add_argument(
        "--plot-episode",
        type=int,
        default=None,
        help="which target to plot/film (default: the first one that needs a hop)",
    )
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    ap.add_argument(
        "--env",
        type=str,
        default=None,
        choices=sorted(ENVS),
        help="the task a controller (scripted, --controller) acts in; a "
        "task that draws its ground (HopRoverTerrain-v0: slopes from "
        f"U{task_ground('HopRoverTerrain-v0')['slope']} rad) also draws "
        "one held-out slope per episode from its range (seeded by --seed) "
        "and sets its roughness, for every policy",
    )
    ap.add_argument(
        "--slope",
        type=float,
        default=None,
        help="one ground slope [rad] for every episode and policy",
    )
    ap.add_argument(
        "--roughness",
        type=float,
        default=None,
        help="rough-terrain bounces [rad] for every episode and policy",
    )
    ap.add_argument(
        "--suite",
        nargs="?",
        type=int,
        const=0,
        default=None,
        metavar="VERSION",
        help="evaluate on the frozen test suite of --env (default HopRover-v0; "
        "the newest version, or VERSION) and score against its references",
    )
    ap.add_argument(
        "--batch",
        type=int,
        default=256,
        help="episodes run side by side in one vector env (default 256)",
    )
    ap.add_argument(
        "--ray",
        nargs="?",
        const="",
        default=None,
        metavar="ADDRESS",
        help="run the episodes as Ray tasks, one batch each: on a local Ray, "
        "or on the cluster at ADDRESS (or RAY_ADDRESS); same results",
    )
    ap.add_argument(
        "--workers",
        type=int,
        default=None,
        help="worker processes for a policy that plays its episodes in them "
        "(mpc; default: one per core, 1 = in this process); same results",
    )
    from hoprover_env.training.ray_utils import SHIP_CODE_HELP

    ap.add_argument("--ship-code", action="store_true", help="with --ray: " + SHIP_CODE_HELP)
    args = ap.parse_args(_join_dash_values(sys.argv[1:] if argv is None else list(argv)))
    if args.batch < 1:
        ap.error(f"--batch must be at least 1, got {args.batch}")
    if args.episodes < 1:
        ap.error(f"--episodes must be at least 1, got {args.episodes}")
    if args.workers is not None and args.workers < 1:
        ap.error(f"--workers must be at least 1, got {args.workers}")
    if not (math.isfinite(args.control_dt) and args.control_dt > 0):
        ap.error(f"--control-dt must be a finite number > 0, got {args.control_dt}")
    low, high = args.target_range
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        ap.error(f"--target-range wants finite LOW < HIGH, got {low} {high}")
    if args.targets is not None:
        try:
            args.targets = np.array([float(v) for v in args.targets.split(",")])
        except ValueError:
            ap.error(f"--targets must be comma-separated numbers, got {args.targets!r}")
        if not np.all(np.isfinite(args.targets)):
            ap.error(f"--targets must be finite numbers, got {','.join(map(str, args.targets))}")
    n_targets = len(args.targets) if args.targets is not None else args.episodes
    if args.plot_episode is not None and not 0 <= args.plot_episode < n_targets:
        ap.error(f"--plot-episode {args.plot_episode} is not a target index (0..{n_targets - 1})")
    return args


def _join_dash_values(argv: list[str]) -> list[str]:
    """`--targets -0.5,0.3`: argparse takes a value starting with '-' for an option unless it
    is a plain negative number, so a negative first target needs the `--targets=...` form.
    Glue the value to its option before argparse sees it."""
    out, i = [], 0
    while i < len(argv):
        if (
            argv[i] == "--targets"
            and i + 1 < len(argv)
            and argv[i + 1].startswith("-")
            and not argv[i + 1].startswith("--")
        ):
            out.append(f"--targets={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def format_table(rows) -> str:
    head = (
        f"{'policy':<22}{'success':>9}{'median TTRTP':>14}{'p90 TTRTP':>11}"
        f"{'broken':>8}{'wall s/ep':>11}"
    )
    lines = [head, "-" * len(head)]
    for name, s in rows:
        med = "-" if math.isnan(s["median_ttrtp"]) else f"{s['median_ttrtp']:.1f} s"
        p90 = "-" if math.isnan(s["p90_ttrtp"]) else f"{s['p90_ttrtp']:.1f} s"
        lines.append(
            f"{name:<22}{s['success_rate']:>8.1%}{med:>14}{p90:>11}"
            f"{s['broken']:>8d}{s['wall_per_episode']:>11.3f}"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    try:
        return _main(argv)
    except KeyboardInterrupt:
        # one line, not a traceback; 130 is the shell's code for a SIGINT exit
        print("\ninterrupted", file=sys.stderr)
        return 130


def _main(argv=None) -> int:
    try:
        args = parse_args(argv)
    except SystemExit as exc:  # argparse has printed its one-line error (or --help)
        return exc.code if isinstance(exc.code, int) else 2
    suite = None
    if args.suite is not None:
        if args.targets is not None or args.slope is not None or args.roughness is not None:
            print(
                "error: --suite fixes the episodes; drop --targets/--slope/--roughness",
                file=sys.stderr,
            )
            return 2
        from hoprover_env.evaluation import suites

        try:
            suite = suites.load(args.env or "HopRover-v0", args.suite or None)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        targets = suite.targets
    elif args.targets is not None:
        targets = args.targets
    else:
        targets = seeded_targets(args.episodes, args.seed, *args.target_range)
    specs = (
        args.policy
        if args.policy is not None
        else ([] if args.controller else ["scratch", "hop", "bundled", "scripted"])
    )
    try:
        policies = [load_policy(s, control_dt=args.control_dt, seed=args.seed) for s in specs]
        policies += [load_controller(c, args.control_dt) for c in args.controller]
    except (FileNotFoundError, ValueError, AttributeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    ground = suite.terrain() if suite else terrain_conditions(args, len(targets))
    if args.env is not None:
        for pol in policies:  # controllers act in the task asked for
            if not hasattr(pol, "env_id"):
                pol.env_id = args.env
    names = [p.name for p in policies]
    for pol, spec in zip(policies, specs):
        # two run directories both hold best_model.zip: name those rows by what was asked for
        if names.count(pol.name) > 1:
            pol.name = spec.rstrip("/\\")

    rows, all_results = [], []
    if args.ray is not None and (ground or suite):
        print(
            "error: --ray evaluates on the contest's flat ground; run --env/--slope/"
            "--roughness locally",
            file=sys.stderr,
        )
        return 2
    if args.ray is not None:
        jobs = [("policy", s, p.name) for s, p in zip(specs, policies)]
        jobs += [("controller", c, p.name) for c, p in zip(args.controller, policies[len(specs) :])]
        try:
            from hoprover_env.training.ray_eval import evaluate_on_ray
            from hoprover_env.training.ray_utils import ClusterCodeError
        except ImportError as exc:
            print(f"error: --ray needs Ray: pip install 'hoprover[ray]' ({exc})", file=sys.stderr)
            return 2
        t0 = time.perf_counter()
        try:
            by_name = evaluate_on_ray(
                jobs,
                targets,
                args.control_dt,
                args.seed,
                args.batch,
                address=args.ray or None,
                ship_code=args.ship_code,
            )
        except ClusterCodeError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        for _, _, name in jobs:
            rows.append((name, summarize(by_name[name])))
            all_results.extend(by_name[name])
        print(
            f"  {len(jobs)} policies x {len(targets)} episodes on Ray in "
            f"{time.perf_counter() - t0:.1f} s",
            file=sys.stderr,
        )
    for pol in policies if args.ray is None else []:
        bar = None
        if not args.no_progress and len(targets) > 20:
            from tqdm import tqdm

            bar = tqdm(total=len(targets), desc=pol.name, unit="ep", leave=False)
        progress = (lambda k, b=bar: b.update(k - b.n)) if bar else None
        t0 = time.perf_counter()
        try:
            if suite:  # each episode as frozen (suites.run)
                results = suites.run_results(
                    pol, suite, batch=args.batch, progress=progress, workers=args.workers
                )
            else:
                results = run_episodes(
                    pol,
                    targets,
                    batch=args.batch,
                    progress=progress,
                    terrain=ground,
                    workers=args.workers,
                )
        except ValueError as exc:  # a bad --slope / --roughness, named by the env
            print(f"error: {exc}", file=sys.stderr)
            return 2
        if bar:
            bar.close()
        rows.append((pol.name, summarize(results)))
        all_results.extend(suites.judged(results, suite) if suite else results)
        print(
            f"  {pol.name}: {len(results)} episodes in {time.perf_counter() - t0:.1f} s",
            file=sys.stderr,
        )
    where = (
        ""
        if not ground
        else (
            f"; slope {args.slope} rad"
            if args.slope is not None
            else f"; slopes U{task_ground(args.env).get('slope')} rad"
            if "slope" in ground
            else ""
        )
        + (f", roughness {ground['roughness'][0]} rad" if "roughness" in ground else "")
    )
    if suite:
        print(
            f"\nthe {suite.name}-v{suite.version} suite of {args.env or 'HopRover-v0'} "
            f"({len(suite)} episodes, checksum {suite.checksum[:12]}); TTRTP over the "
            "successful episodes\n"
        )
    else:
        print(
            f"\n{len(targets)} targets (seed {args.seed}, range {tuple(args.target_range)}"
            f"{where}); TTRTP over the successful episodes\n"
        )
    print(format_table(rows))
    if suite:
        from hoprover_env.evaluation.scores import format_table as score_table
        from hoprover_env.evaluation.scores import summarize as score

        print(
            "\nagainst the best-known references (score = reference / TTRTP, 0 on "
            "failure; 95 % bootstrap intervals over the episodes):\n"
        )
        print(
            score_table(
                [
                    score(name, [r["score"] for r in all_results if r["policy"] == name])
                    for name, _ in rows
                ]
            )
        )

    if args.json:
        write_json(
            args.json,
            {
                "summary": dict(rows),
                "episodes": [r if isinstance(r, dict) else r.as_dict() for r in all_results],
            },
        )
    if args.csv:
        buf = io.StringIO()
        dicts = [r if isinstance(r, dict) else r.as_dict() for r in all_results]
        w = csv.DictWriter(buf, fieldnames=list(dicts[0]))
        w.writeheader()
        for r in dicts:
            w.writerow(r)
        atomic_write(args.csv, buf.getvalue())
    if args.plot or args.video:
        from hoprover_env.evaluation.replay import record_episode

        k = args.plot_episode
        if k is None:  # the first target more than a body width away: a real hop
            far = np.flatnonzero(np.abs(targets) > 0.15)
            k = int(far[0]) if far.size else 0
        rec = record_episode(
            policies[0], float(targets[k]), terrain={key: v[k] for key, v in ground.items()}
        )
        if args.plot:
            from hoprover_env.evaluation.plots import nine_figures

            paths = nine_figures(rec, args.plot)
            print(f"\nwrote {len(paths)} figures to {args.plot}")
        if args.video:
            from hoprover_env.evaluation.replay import write_video

            try:
                write_video(rec, args.video)
            except (RuntimeError, ImportError) as exc:
                print(f"error: {exc}", file=sys.stderr)
                return 2
            print(f"wrote {args.video}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
