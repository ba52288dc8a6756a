"""RLlib glue (pip install "hoprover[ray]"): an env creator for
`ray.tune.registry.register_env` that builds the native vector env when RLlib asks for
`num_envs` (`gym_env_vectorize_mode="vector_entry_point"`), and a callback that logs the
contest judge's verdict of each episode as RLlib metrics. It lives in the installed
package so that EnvRunner processes, on any machine with hoprover installed, can
unpickle both. See examples/rllib_ppo.py.
"""

from __future__ import annotations

from ray.rllib.callbacks.callbacks import RLlibCallback

from hoprover_env.envs.registry import env_class, task, vector_env_class


def make_env(env_config):
    """RLlib's env creator. `env_config` (an EnvContext: a dict of env keyword arguments,
    with worker_index etc. as attributes) becomes the env's kwargs; its "env_id" (default
    "HopRover-v0", any registered hoprover id) picks the task, whose fixed arguments (the
    contest's target) come first. With `num_envs` in it (RLlib's vector_entry_point mode)
    the task's native vector env steps all of a runner's sub-envs in one numba call.

    Returns the task's env, or its vector env of `num_envs` sub-envs. Raises
    ValueError/TypeError for an unknown id or a bad env argument, naming it."""
    kwargs = dict(env_config)
    env_id = kwargs.pop("env_id", "HopRover-v0")
    num_envs = kwargs.pop("num_envs", None)
    kwargs = {**task(env_id).kwargs, **kwargs}
    if num_envs is None:
        return env_class(env_id)(**kwargs)
    return vector_env_class(env_id)(num_envs=num_envs, **kwargs)


class HopRoverMetrics(RLlibCallback):
    """Per finished episode: hoprover_success, hoprover_broken and (on success)
    hoprover_ttrtp [s], averaged by RLlib into `result["env_runners"]`. Pass the class as
    ``config.callbacks(HopRoverMetrics)``."""

    def on_episode_end(self, *, episode, metrics_logger=None, **kwargs):
        """Log the judge's verdict from the episode's last info: success (0/1), broken
        (0/1) and, on success, the TTRTP [s]. RLlib calls it; returns None."""
        info = episode.get_infos(-1)
        success = bool(info.get("is_success", False))
        metrics_logger.log_value("hoprover_success", float(success))
        metrics_logger.log_value("hoprover_broken", float(info.get("broken", False)))
        if success:
            metrics_logger.log_value("hoprover_ttrtp", float(info["ttrtp"]))
