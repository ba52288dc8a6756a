"""The RL tasks over the physics core: what an action does, what a step returns.

=================  ==================================================================
``layout``         the task configuration vector E (one slot each)
``observation``    the observation vector (one slot each), observe, the reference and
                   landing points the observation and the reward share
``common``         the end of every step (`finish`), the batched loops, `build`
``torque``         the torque task: action -> torque held for one control period
``hop``            the hop-level task: action -> one hop flown by a built-in controller
``terrain``        the torque task on sloped, rough ground: its step, the observation
                   plus the slope
=================  ==================================================================

A new task is one module with a step template calling ``ADVANCE`` and
``KERNELS = build("name", step)``; docs/ARCHITECTURE.md walks through one.
"""
