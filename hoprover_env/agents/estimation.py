"""A state estimator for the mission task (HopRoverMission-v0): what a contest controller
sees when the rover senses its state through noise.

`MissionEstimator` turns one rover's readings (tasks/mission.py's observation) into the
contest controller's inputs (pos, vel, theta, omega, contact state), with covariances:

* **Attitude**: a Kalman filter on (theta, bias). It propagates theta with the measured
  rate, walks the bias as the sensor's datasheet says (`bias_walk`), and updates with
  the attitude reading (theta + bias + noise). At rest the rover lies on its bottom
  face, so theta = 0 is a measurement too: each rest calibrates the bias.
* **Slope**: the mean of the inclinometer's readings (its variance falls as 1/n).
* **Position**: the last fix (variance `fix_noise`^2 when fresh; its age is reported).
  Between fixes the rover does not know where it is; nothing is extrapolated.
* **Contact state**: 'F' (at rest) when a fix is fresh: the sensors only fix at rest.
  Otherwise the gyro tells flight from contact: in flight the rate changes by exactly
  T / I per second under the applied torque T (the command, within the actuator's few
  per cent; a constant rate without torque), on the ground pivoting about a corner it
  changes at most a quarter of that (the corner's inertia is four times the centre's
  for this cube) and impacts change it abruptly. The estimate keeps its last verdict
  while the two cannot be told apart (no torque, no rotation). A bounce is seen one
  control period late: the period of the impact reads as contact. A slow rocking on a
  corner after a landing (a few mrad/s, where gravity's torque is as small as the
  hold's) can read as flight; the hold torques it then commands are as small.
* **Velocity**: not estimated (0); the contest controllers here use it only in flight,
  through their attitude hold, which needs theta and omega.

`estimated_params` is the ground a planner should assume: the nominal rover, the slope
estimate, smooth ground (the restitution and friction stay the nominal ones: the
mission does not know them).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hoprover_env import core
from hoprover_env.agents.scripted import in_band
from hoprover_env.core.params import RoverParams
from hoprover_env.tasks import mission

FLIGHT_MATCH = 0.6  # rate change / (T / I) above this reads as flight


class MissionEstimator:
    """One rover's estimate from its mission readings. `config` is the env's
    MissionEnvConfig: its sensors' datasheet (noise levels, control period), not the
    realisations."""

    def __init__(self, config):
        self.config = config
        k = config.noise_scale
        self.sig_att = max(k * config.attitude_noise, 1e-9)
        self.sig_rate = max(k * config.rate_noise, 1e-12)
        self.q_bias = (k * config.bias_walk) ** 2
        self.sig_fix = k * config.fix_noise
        self.sig_incl = k * config.inclinometer_noise
        self.params = config.params
        self.reset()

    def reset(self) -> None:
        """A new episode: the rover has rested, bias unknown within the attitude noise."""
        self.x = np.zeros(2)  # theta, bias
        self.P = np.diag([self.sig_att**2, (3 * self.sig_att) ** 2])
        self.t = None
        self.omega = 0.0
        self.torque = 0.0
        self.state = "F"
        self.slope_sum = 0.0
        self.slope_n = 0
        self.fix = 0.0
        self.fix_age = 0.0

    # ---- the filter -----------------------------------------------------------------
    def update(self, reading: np.ndarray, target_x: float) -> None:
        """Take one control instant's reading (the first mission.OBS_DIM slots of an
        observation) of an episode whose target is `target_x` [m]."""
        r = np.asarray(reading, dtype=np.float64)
        t = r[mission.OBS_TIME] * self.config.episode_time
        dt = 0.0 if self.t is None else max(t - self.t, 0.0)
        omega = r[mission.OBS_RATE] * 0.3
        # the torque commanded over the period that just ended (the reading's slot)
        self.torque = r[mission.OBS_TORQUE] * max(
            abs(self.params.torque_min), abs(self.params.torque_max)
        )
        # predict: theta moves with the mean of the two rate readings (exact under a
        # constant angular acceleration: flight under a held torque), the bias walks.
        # A rate change the held torque does not explain (an impact, a pivot) happened
        # at an unknown instant of the period: theta is then uncertain by up to half
        # that change times the period (uniform: variance / 12 of the full width)
        if self.t is not None:
            self.x[0] += 0.5 * (self.omega + omega) * dt
            unexplained = abs(omega - self.omega - self.torque / self.params.inertia * dt)
            q_theta = (self.sig_rate * dt) ** 2 + (unexplained * dt) ** 2 / 12.0
            self.P = self.P + np.diag([q_theta, self.q_bias * dt])
        # update with the attitude reading: z = theta + bias + v
        z = math.atan2(r[mission.OBS_SIN], r[mission.OBS_COS])
        self._measure(np.array([1.0, 1.0]), z, self.sig_att**2)
        self.fix_age = r[mission.OBS_FIX_AGE] * mission.FIX_AGE_SCALE
        at_rest = self.fix_age == 0.0
        if at_rest:  # flat on the ground: theta = 0
            self._measure(np.array([1.0, 0.0]), 0.0, (1e-3 * self.sig_att) ** 2)
            self.fix = r[mission.OBS_FIX] * 1.0 + target_x
        self.slope_sum += r[mission.OBS_SLOPE] * 0.5
        self.slope_n += 1
        self.state = self._contact(at_rest, omega, dt, self.torque)
        self.omega, self.t = omega, t

    def _measure(self, H, z, R) -> None:
        innovation = z - H @ self.x
        innovation = (innovation + math.pi) % (2 * math.pi) - math.pi
        S = H @ self.P @ H + R
        K = self.P @ H / S
        self.x = self.x + K * innovation
        self.P = (np.eye(2) - np.outer(K, H)) @ self.P

    def _contact(self, at_rest, omega, dt, torque) -> str:
        """The contact state the readings point to (module docstring)."""
        if at_rest:
            return "F"
        if dt <= 0.0:
            return self.state
        expected = torque / self.params.inertia  # rad/s^2 in flight
        seen = (omega - self.omega) / dt
        noise = 3.0 * math.sqrt(2.0) * self.sig_rate / dt
        if abs(seen - expected) > max((1.0 - FLIGHT_MATCH) * abs(expected), noise):
            return "B"  # a pivot, a slide or an impact: not free rotation
        if abs(expected) > 2.0 * noise or abs(omega) > 5.0 * self.sig_rate:
            return "A"  # it turns exactly as a free body would
        return self.state  # nothing tells: still, untorqued

    # ---- what a controller reads ------------------------------------------------------
    @property
    def theta(self) -> float:
        return float(self.x[0])

    @property
    def bias(self) -> float:
        return float(self.x[1])

    @property
    def slope(self) -> float:
        return self.slope_sum / self.slope_n if self.slope_n else 0.0

    @property
    def slope_var(self) -> float:
        return self.sig_incl**2 / max(self.slope_n, 1)

    @property
    def position_var(self) -> float:
        """Variance of the position estimate [m^2]: the fix's when fresh, unbounded
        (inf) once the rover has moved since."""
        return self.sig_fix**2 if self.fix_age == 0.0 else math.inf

    def estimated_params(self) -> RoverParams:
        return dataclasses.replace(
            self.params, slope=float(np.clip(self.slope, -0.5, 0.5)), roughness=0.0
        )

    def controller_inputs(self, target_x: float) -> tuple:
        """(pos, vel, the, omg, posT, t, state) for a contest controller."""
        return (
            np.array([self.fix, self.params.half_height]),
            np.zeros(2),
            self.theta,
            self.omega,
            np.array([target_x, 0.0]),
            float(self.t or 0.0),
            self.state,
        )


class EstimatorBank:
    """One MissionEstimator per sub-env of a vector env, for a policy that acts on a
    task hiding its state (`hides_state`); `reset(n)` with the policy's episodes."""

    def __init__(self):
        self.items: list = []

    def reset(self, n: int) -> None:
        self.items = [None] * n

    def update(self, obs: np.ndarray, venv) -> list:
        """Take every sub-env's reading of this control instant; returns the estimators."""
        if len(self.items) != len(obs):
            self.reset(len(obs))
        for i in range(len(obs)):
            if self.items[i] is None:
                self.items[i] = MissionEstimator(venv.config)
            self.items[i].update(obs[i], float(venv.targets[i]))
        return self.items

    def state_rows(self, venv) -> tuple[np.ndarray, list]:
        """What a planner that reads the kernel's state sees instead: a state row per
        sub-env built from the estimate (the last fix at rest height, the attitude
        estimate, the measured rate, zero velocity, the estimated contact state, the
        band as the fix places it, the time), and the ground each estimator knows of."""
        rows = np.zeros_like(venv.S)
        params = []
        for i, est in enumerate(self.items):
            p = est.estimated_params()
            s = rows[i]
            s[core.S_X], s[core.S_Y], s[core.S_TH] = est.fix, p.half_height, est.theta
            s[core.S_W] = est.omega
            if est.state == "F":  # at rest it lies flat and still
                s[core.S_TH] = s[core.S_W] = 0.0
            s[core.S_T] = est.t or 0.0
            s[core.S_MODE] = core.MODE_LETTERS.index(est.state)
            s[core.S_XT] = venv.targets[i]
            s[core.S_INBAND] = float(est.state == "F" and in_band(est.fix, venv.targets[i], p))
            s[core.S_TTRTP] = math.nan
            params.append(p)
        return rows, params


def hides_state(venv) -> bool:
    """Whether the env's task keeps its state from the policy (HopRoverMission-v0)."""
    return getattr(getattr(venv, "task", None), "hidden_info", None) is not None
