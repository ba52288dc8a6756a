"""The task configuration vector ``E`` shared by every rover of an env: the slots every
task reads, and the range a task's own slots take (the reward's own parameters are in
hoprover_env/tasks/reward.py).

A task that needs parameters of its own (the hop task's controller gains, the mission
task's noise levels) names its slots in its own module, from E_TASK on, and writes them
in its config's `task_vector`; two tasks may use the same slots for different things,
since each env has one task.
"""

E_CONTROL_DT = 0     # control period [s] (the hop task: its controller's period)
E_T_TOTAL = 1        # episode length [s]
E_ACTION_MAP = 2     # ACTION_LINEAR or ACTION_CUBIC (torque task)
E_ACTION_SCALE = 3   # fraction of the torque range reached at |a| = 1 (torque task)
E_TASK = 4           # the first of a task's own slots
N_E = 15             # the vector's length: a task owns slots E_TASK .. N_E - 1

ACTION_LINEAR, ACTION_CUBIC = 0, 1
ACTION_MAPS = {"linear": ACTION_LINEAR, "cubic": ACTION_CUBIC}
