"""Record one episode of a policy and replay it densely for figures and videos.

The policy runs in the environment as usual; its applied torques are then replayed
through `hoprover_env.simulate` with extra samples between control instants
(`sample_dt`), which gives the same physics at plotting resolution. A policy of the
hop-level task (`HopRoverHop-v0`, one action per hop) runs in that task's env; its hops
are replayed by the scripted hopper's launch / attitude-hold / settle controller
(`hoprover_env.agents.scripted.ScriptedHopper`) fed with the launch torques the policy chose.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from gymnasium.vector import AutoresetMode

from hoprover_env import Rollout, core, simulate
from hoprover_env.agents.scripted import ScriptedHopper
from hoprover_env.envs import registry as _registry
from hoprover_env.envs.registry import vector_env_class


def _launch_torque(action: float, venv) -> float:
    """The launch torque [N m] the hop-level env `venv` flies for `action` (its task's
    own map, TaskSpec.action_torque)."""
    return float(venv.task.action_torque(action, venv.P[0], venv.config.task_vector()))


@dataclasses.dataclass
class Recording:
    """One recorded episode: the policy's name, the target [m], the env judge's TTRTP
    [s] (None if not reached), whether the rover broke, the control period [s] and the
    dense replay (`hoprover_env.Rollout`)."""

    policy: str
    target_x: float
    ttrtp: float | None
    broken: bool
    control_dt: float
    rollout: Rollout


def record_episode(
    policy,
    target_x: float,
    env_kwargs: dict | None = None,
    sample_dt: float = 0.1,
    terrain: dict | None = None,
) -> Recording:
    """Run `policy` (see `hoprover_env.agents.policies`) for one episode towards `target_x` [m]
    in the vector env of its task (`policy.env_id`, default HopRover-v0) and replay it with
    samples every `sample_dt` [s] (at most one control period).

    `env_kwargs` configure the env; the policy's own `env_kwargs` take precedence.
    `terrain` fixes this episode's ground, {"slope": rad, "roughness": rad} (either may
    be left out), as `hoprover_env.evaluation.episodes.run_episodes` does per episode; the
    replay flies the same slope and, on rough ground, the same bumps (the env's seed of the draws).
    Returns a `Recording`; its TTRTP is the judge's of the env that ran the episode.
    Raises ValueError for bad env arguments (as the env does).
    """
    kwargs = {**(env_kwargs or {}), **getattr(policy, "env_kwargs", {})}
    kwargs.pop("target_x", None)
    env_id = getattr(policy, "env_id", "HopRover-v0")
    venv = vector_env_class(env_id)(1, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
    hops = _registry.task(env_id).hops  # one action = one hop's launch torque
    ground = {k: float(v) for k, v in (terrain or {}).items()}
    obs, _ = venv.reset(seed=0, options={"target_x": np.array([target_x]), **ground})
    policy.reset(1)
    params = venv.params[0]
    # on rough ground the replay meets the episode's bumps: the env's key of the draws
    # (sub-env 0 is rover 0, as simulate's run is), read before the autoreset redraws it
    seed = int(getattr(venv, "terrain_seeds", [-1])[0])
    torques = []
    while True:
        action = policy.act(obs, venv)
        if hops:
            torques.append(_launch_torque(float(action[0, 0]), venv))
        obs, _, term, trunc, info = venv.step(action)
        if not hops:
            torques.append(
                float(venv.S[0, core.S_TORQUE])
                if not (term[0] or trunc[0])
                else _applied(action[0, 0], params)
            )
        if term[0] or trunc[0]:
            success = bool(info["final_info"]["is_success"][0])
            ttrtp = float(info["final_info"]["ttrtp"][0]) if success else None
            t_end = ttrtp if success else len(torques) * venv.config.control_dt
            break
    dt = venv.config.control_dt
    controller: _HopReplay | np.ndarray
    if hops:
        controller = _HopReplay(torques, params, dt, venv.config)
        t_end = ttrtp if ttrtp is not None else venv.config.episode_time
    else:
        controller = np.array(torques)
        t_end = min(max(t_end, dt), len(torques) * dt)
    roll = simulate(
        controller,
        t_end=t_end,
        control_dt=dt,
        target_x=target_x,
        integrator=venv.config.integrator,
        impact_law=venv.config.impact_law,
        params=params,
        sample_dt=min(sample_dt, dt),
        seed=seed if params.roughness > 0.0 and seed >= 0 else None,
    )
    # the replay stops at the TTRTP itself, where its own judge may not yet have closed the
    # 5 s window: the env's judge, which ran the episode, gives the TTRTP
    return Recording(
        getattr(policy, "name", "policy"),
        target_x,
        ttrtp if ttrtp is not None else roll.ttrtp,
        roll.broken,
        dt,
        roll,
    )


class _HopReplay(ScriptedHopper):
    """The hop-level task's hops as a contest controller: the scripted hopper's launch,
    attitude hold and settling, with the recorded launch torques instead of its plans."""

    def __init__(self, torques, params, control_dt, config):
        super().__init__(params=params, control_dt=control_dt, kp=config.hold_kp, kd=config.hold_kd)
        self.queue = list(torques)

    def plan(self, x0, xt, t0, remaining):
        return (self.queue.pop(0), None) if self.queue else None


def _applied(action: float, params) -> float:
    a = float(np.clip(action, -1.0, 1.0))
    return params.torque_min + 0.5 * (a + 1.0) * (params.torque_max - params.torque_min)


def write_video(rec: Recording, path: str, max_frames: int = 300, fps: int = 20) -> None:
    """Write the recording `rec` as a GIF (Pillow) or MP4 (imageio-ffmpeg) at `path`:
    at most `max_frames` frames spread over the run, shown at `fps` frames per second.
    Raises RuntimeError for an MP4 without imageio-ffmpeg."""
    try:
        import imageio.v2 as imageio
    except ImportError as exc:
        raise ImportError(
            "writing a video needs imageio, in the render extra: pip install 'hoprover[render]'"
        ) from exc
    from hoprover_env.envs.rendering import Renderer

    roll = rec.rollout
    idx = np.unique(np.linspace(0, len(roll.t) - 1, min(max_frames, len(roll.t))).astype(int))
    renderer = Renderer(mode="rgb_array")
    frames, trace, shown = [], [], set(idx.tolist())
    for i in range(len(roll.t)):
        trace.append((roll.x[i], roll.y[i]))
        if i in shown:
            frames.append(
                renderer.draw(
                    (roll.x[i], roll.y[i], roll.theta[i]),
                    roll.params,
                    rec.target_x,
                    list(trace),
                    roll.t[i],
                    roll.state[i],
                    roll.torque[i],
                )
            )
    if path.lower().endswith(".gif"):
        imageio.mimsave(path, frames, duration=1000 // fps, loop=0)
        return
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        raise RuntimeError(
            f"writing {path} needs imageio-ffmpeg (pip install "
            "imageio-ffmpeg, or pip install -e '.[render]'); a .gif needs "
            "nothing more"
        ) from None
    imageio.mimsave(path, frames, fps=fps)
