"""The whole recipe of a plan-table clone from one config (`pipeline`): the table
(research/plan_clone/plan_table.py `build`, `refine_edge`), the nudge at the band's edge
(research/plan_clone/nudge.py), the teacher's demonstrations (`collect_table`), fits and
DAgger rounds, and the gated network. Its command line is plan_table's:

    python -m research.plan_clone.plan_table pipeline \\
        --config research/plan_clone/plan_clone.yaml --out runs/plan_clone
"""

from __future__ import annotations

import json

from hoprover_env.util.files import write_npz
from research.plan_clone.plan_table import (
    TABLE_DEFAULTS,
    build,
    collect_table,
    load_table,
    refine_edge,
)

PIPELINE_KEYS = {
    "table",
    "edge",
    "nudge",
    "in_band",
    "cells",
    "demonstrations",
    "fit",
    "dagger",
    "dagger_fit",
    "symmetric",
    "deadzone",
    "edge_dagger",
    "flight",
    "hold",
    "rest",
}


def pipeline(config_path, out, log=print) -> dict:
    """The whole recipe from one config (research/plan_clone/plan_clone.yaml): the table, the
    demonstrations, a fit, and DAgger rounds each followed by a fit on everything so
    far (warm-started from the clone before it, with `dagger_fit` overriding `fit`'s
    settings); the last clone is exported as OUT/best_model.zip (loadable by `load_policy`)
    and judged into OUT/judge.json; with `nudge`, the nudge branch is then fitted and the
    gated network of both (OUT/plan_clone.pt, research.plan_clone.gated) is what is judged,
    after `edge_dagger` rounds (`research.plan_clone.nudge.gated_rounds`). With `cells`, the
    demonstrations and DAgger rounds fly targets drawn within the grid rows' cells
    (`collect_table`). Each table, collection and main-branch clone is kept in OUT, so
    a killed run starts again from its last finished one (the last nudge branch is
    fitted again)."""
    from pathlib import Path

    import yaml

    from hoprover_env.util.files import write_json
    from research.plan_clone.clone_study import fit, load_clone, report

    cfg = yaml.safe_load(Path(config_path).read_text())
    unknown = set(cfg) - PIPELINE_KEYS
    if unknown:
        raise SystemExit(
            f"error: unknown config key(s) {sorted(unknown)} in {config_path}; "
            f"expected {sorted(PIPELINE_KEYS)}"
        )
    nudge_cfg = cfg["nudge"] if isinstance(cfg.get("nudge"), dict) else {}
    if set(nudge_cfg) - {"margin"}:
        raise SystemExit(
            f"error: unknown key(s) {sorted(set(nudge_cfg) - {'margin'})} under "
            f"`nudge` in {config_path}; expected ['margin']"
        )
    nudge_margin = int(nudge_cfg.get("margin", 1))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    tpath = out / "table.npz"
    if not tpath.exists():
        write_npz(tpath, **build({**TABLE_DEFAULTS, **cfg.get("table", {})}, log))
    if cfg.get("edge"):  # rows just beyond the band's edge
        epath = out / "table_edge.npz"
        if not epath.exists():
            write_npz(epath, **refine_edge(load_table(tpath), cfg["edge"], log=log))
        tpath = epath
    if cfg.get("nudge"):  # the edge's nudges as state feedback (research/plan_clone/nudge.py)
        from research.plan_clone.nudge import choose, search, with_family

        npath = out / "table_nudge.npz"
        if not npath.exists():
            write_npz(
                npath,
                **with_family(load_table(tpath), choose(search(log=log), margin=nudge_margin)),
            )
        tpath = npath
    table = load_table(tpath)
    in_band, cells = cfg.get("in_band", 120), bool(cfg.get("cells", False))
    data = []
    for d in cfg["demonstrations"]:
        path = out / f"demo_noise{d['noise']}_seed{d['seed']}.npz"
        if not path.exists():
            obs, act, ret = collect_table(
                table, d["noise"], d["seed"], in_band, cells=cells, log=log
            )
            write_npz(path, obs=obs, act=act, ret=ret)
        data.append(str(path))
    fcfg = dict(cfg.get("fit", {}))
    activation, arch = fcfg.pop("activation", None), fcfg.pop("net_arch", None)
    features = fcfg.pop("features", None)
    rounds = cfg.get("dagger") or []
    res = None
    for r in range(len(rounds) + 1):
        last = r == len(rounds)
        clone_path = out / f"clone_{r}.pkl"
        settings = fcfg if r == 0 else {**fcfg, **cfg.get("dagger_fit", {})}
        judged = out / f"judge_{r}.json"
        if (
            clone_path.exists()
            and judged.exists()
            and (not last or (out / "best_model.zip").exists())
        ):
            res = json.loads(judged.read_text())
            log(f"clone {r}: kept from an earlier run ({clone_path})")
        else:
            res = fit(
                data,
                activation=activation,
                arch=arch,
                features=features,
                save=str(clone_path),
                init=None if r == 0 else str(out / f"clone_{r - 1}.pkl"),
                export_dir=str(out) if last else None,
                log=log,
                **settings,
            )
            log(f"clone {r} ({len(data)} collections):")
            write_json(judged, res)
        report(res, log)
        if last:
            break
        path = out / f"dagger_{r + 1}_seed{rounds[r]['seed']}.npz"
        if not path.exists():
            learner = load_clone(str(clone_path), activation, arch, features=features)
            obs, act, ret = collect_table(
                table, 0.0, rounds[r]["seed"], in_band, learner, cells=cells, log=log
            )
            write_npz(path, obs=obs, act=act, ret=ret)
        data.append(str(path))
    if cfg.get("nudge"):
        from research.plan_clone.nudge import gated_rounds

        res = gated_rounds(
            cfg,
            out,
            table,
            data,
            str(out / f"clone_{len(rounds)}.pkl"),
            {**fcfg, **cfg.get("dagger_fit", {})},
            dict(activation=activation, arch=arch, features=features),
            log,
        )
    write_json(out / "judge.json", res)
    return res
