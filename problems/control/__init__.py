"""Control: the way from a planned step (:mod:`problems.walking`) to a walking robot.

* :mod:`simulation`: the hybrid plant (single and double support, strikes, falls, pushes);
* :mod:`feet_simulation`: the walker on feet on a floating base, compliant heels and balls;
* :mod:`linearisation`: the return map, its exact Jacobian, fixed points, Floquet multipliers;
* :mod:`lqr`: linearisation along the step and the periodic LQR through the impact;
* :mod:`tracking`: references indexed by the hip's phase and the controllers that track them;
* :mod:`feedback`: the designed feedback, its gains in the file, closed-loop checks;
* :mod:`feet_law`: the drives' law of the step on feet (joint PD per contact branch);
* :mod:`mujoco`, :mod:`mujoco_feet`: the plan and its feedback run in MuJoCo
  (``pip install ".[mujoco]"``).

Imports run one way: control reads the walking plans, never the reverse (held by
``tests/test_architecture.py``).
"""
