"""The task configuration vector ``E`` shared by every rover of an env: one home for
each slot (the reward's own parameters are in hoprover_env/tasks/reward.py)."""

E_CONTROL_DT = 0     # control period [s] (the hop task: its controller's period)
E_T_TOTAL = 1        # episode length [s]
E_ACTION_MAP = 2     # ACTION_LINEAR or ACTION_CUBIC (torque task)
E_ACTION_SCALE = 3   # fraction of the torque range reached at |a| = 1 (torque task)
E_HOLD_KP = 4        # attitude hold in flight [1/s^2] (hop task)
E_HOLD_KD = 5        # [1/s] (hop task)
E_LAUNCH_MAX = 6     # longest a launch torque is held before giving up [s] (hop task)
E_LAUNCH_MIN = 7     # weakest launch, a multiple of the tipping torque m g r (hop task)
E_ATT_NOISE = 8     # attitude sensor noise, 1 sigma [rad] (mission task, as the rest)
E_RATE_NOISE = 9    # rate sensor noise [rad/s]
E_BIAS_WALK = 10    # attitude bias random walk [rad / sqrt(s)]
E_FIX_NOISE = 11    # position fix noise [m]
E_FIX_REST = 12     # time at rest before a fix [s]
E_INCL_NOISE = 13   # inclinometer noise [rad]
E_HISTORY = 14      # readings in the observation, newest first (mission task)
N_E = 15

ACTION_LINEAR, ACTION_CUBIC = 0, 1
ACTION_MAPS = {"linear": ACTION_LINEAR, "cubic": ACTION_CUBIC}
