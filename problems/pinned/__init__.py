"""The seed paper's setting: a periodic gait on a pinned stance foot (:mod:`gait`:
``periodic_gait``) and its feedback (:mod:`feedback`: the period map, a time-indexed LQR, runs
in the product's simulation and in MuJoCo)."""
