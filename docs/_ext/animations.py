"""Animations of the bundled policies for the environment pages, made by running them.

    python docs/_ext/animations.py HopRover-v0 scratch 0.7 out.gif

One episode of a bundled policy (`hoprover_env.policies.load_policy`) towards one target,
replayed densely (`hoprover_env.replay.record_episode`) and drawn by the env's own renderer
(`hoprover_env.replay.write_video`): the GIF of `evaluate.py --video`. A JSON file beside the
GIF records what was run and the judge's verdict, for the caption.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# frames and rate of the site's GIFs: about 0.6-0.9 MB each
MAX_FRAMES = 240
FPS = 16


def make_animation(env_id: str, policy: str, target_x: float, out: Path) -> dict:
    """Run `policy` on `env_id` towards `target_x` [m], write the GIF `out` and its JSON
    (policy, target, TTRTP [s] or None, broken, seconds taken). Returns that record.
    Raises ValueError if the policy does not act in `env_id`'s task."""
    from hoprover_env.policies import load_policy
    from hoprover_env.replay import record_episode, write_video
    import hoprover_env

    t0 = time.perf_counter()
    pol = load_policy(policy)
    own = getattr(pol, "env_id", "HopRover-v0")
    fixed = hoprover_env.ENVS[env_id].kwargs
    if hoprover_env.task(own).env != hoprover_env.task(env_id).env:   # another kind of env
        raise ValueError(f"policy {policy!r} acts in {own}, not in {env_id}")
    if "target_x" in fixed:
        target_x = float(fixed["target_x"])
    rec = record_episode(pol, target_x)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp.gif")
    write_video(rec, str(tmp), max_frames=MAX_FRAMES, fps=FPS)
    tmp.replace(out)
    meta = {"env_id": env_id, "policy": policy, "target_x": target_x, "ttrtp": rec.ttrtp,
            "broken": rec.broken, "seconds": round(time.perf_counter() - t0, 1),
            "bytes": out.stat().st_size}
    out.with_suffix(".json").write_text(json.dumps(meta, indent=1))
    return meta


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    env_id, policy, target, path = sys.argv[1:5]
    print(make_animation(env_id, policy, float(target), Path(path)))
