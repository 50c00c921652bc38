"""Walking: a step with heel strike, leg swap and an optional double support, planned.

* :mod:`step`: the walking step on point feet as an optimal control problem (``walking_step``),
  its gait;
* :mod:`footed`: the step on feet (flat foot, heel rise, double support);
* :mod:`feet`: the walker's feet as contacts (stance H0, the swing leg's end), for both;
* :mod:`plots`: the gait's pictures and GIF.

The way from a plan to a robot (the hybrid simulation, the return map, the LQR, the laws and
MuJoCo) lives in :mod:`problems.control`.
"""
