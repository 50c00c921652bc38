"""Walking: a step with heel strike, leg swap and an optional double support, and the way from
the plan to a robot.

* :mod:`step`: the walking step as an optimal control problem (``walking_step``), its gait;
* :mod:`feet`: the walker's feet as contacts (stance H0, the swing leg's end), for both;
* :mod:`simulation`: the hybrid plant (single and double support, strikes, falls, pushes);
* :mod:`linearisation`: the return map, its exact Jacobian, fixed points, Floquet multipliers;
* :mod:`lqr`: linearisation along the step and the periodic LQR through the impact;
* :mod:`control`: references and the controllers that track them;
* :mod:`feedback`: the designed feedback, its gains in the file, closed-loop checks;
* :mod:`mujoco`: the plan and its feedback run in MuJoCo (``pip install ".[mujoco]"``);
* :mod:`plots`: the gait's pictures and GIF.
"""
