"""What the single env and the vector env of every task share, written once: their
spaces, the render-mode check and the info dict (the table in env.py).

The info's values are computed by each env in its own shape (numpy scalars in the
single env, where a step costs about 2 us and array arithmetic on one row would double
it; arrays in the vector env) and arranged here, so that both carry the same keys,
types and meanings.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from numba import types as nt

from hoprover_env import core
from hoprover_env.jit.compiler import MAT, kernel
from hoprover_env.tasks import reward
from hoprover_env.tasks.common import TTRTP_NOT_REACHED  # noqa: F401  (the envs' import)

NO_TERRAIN_SEED = -1  # info["terrain_seed"] on smooth ground (nothing is drawn)


def task_spaces(task, config) -> tuple[spaces.Box, spaces.Box]:
    """(action space, observation space) of one rover of a task (tasks.common.TaskSpec)
    under its config."""
    low, high = task.bounds(config)
    return (
        spaces.Box(-1.0, 1.0, (task.action_dim,), np.float32),
        spaces.Box(low, high, dtype=np.float32),
    )


def check_render_mode(render_mode, modes) -> None:
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode must be one of {list(modes)}, got {render_mode!r}")


def info(is_success, ttrtp, state, target_x, broken, n_events, slope, terrain_seed) -> dict:
    """The basic info of a step, of one rover (numpy scalars) or of N (arrays):

    is_success (bool), ttrtp (float64, TTRTP_NOT_REACHED before), state (int64 contact
    state code), target_x (float64), broken (bool), n_events (int64), slope (float64),
    terrain_seed (int64, NO_TERRAIN_SEED on smooth ground)."""
    return {
        "is_success": is_success,
        "ttrtp": ttrtp,
        "state": state,
        "target_x": target_x,
        "broken": broken,
        "n_events": n_events,
        "slope": slope,
        "terrain_seed": terrain_seed,
    }


def full_info(S: np.ndarray, P: np.ndarray, RM: np.ndarray) -> dict:
    """What info_level="full" adds, for one rover's rows (1-D) or N (2-D): the time, the
    rover's state (x, y, theta, vx, vy, omega), the contact forces (fAx, fAy, fBx, fBy)
    and the reward's terms."""
    if S.ndim == 1:
        out = {
            "t": np.float64(S[core.S_T]),
            "rover_state": S[:6].copy(),
            "contact_forces": np.array(core.contact_forces(S, P)),
        }
    else:
        forces = np.zeros((len(S), 4))
        contact_forces_rows(S, P, forces)
        out = {"t": S[:, core.S_T].copy(), "rover_state": S[:, :6].copy(), "contact_forces": forces}
    out.update(reward.terms_info(RM))
    return out


@kernel(nt.void(MAT, MAT, MAT))
def contact_forces_rows(S, P, out):
    """core.contact_forces of every row: out[i] = (fAx, fAy, fBx, fBy)."""
    for i in range(S.shape[0]):
        f = core.contact_forces(S[i], P[i])
        for j in range(4):
            out[i, j] = f[j]


def object_rows(rows: np.ndarray) -> np.ndarray:
    """A 1-D object array of the rows of a 2-D array (copies), built without a Python
    loop over them (Gymnasium's final_obs)."""
    out = np.empty(len(rows) + 1, dtype=object)
    out[:-1] = list(rows.copy())
    return out[:-1]
