"""What every gait problem shares: the paper's gait law (22) (:mod:`law`), a biped seen in a
linkage (:mod:`biped`), the gait problems' common base (:mod:`problem`: objectives, torque
limits, the law's benchmark cost, the solved gait), the accuracy presets (:mod:`accuracy`) and
the verification of a gait's torque file against the physics (:mod:`verification`).

The gaits themselves: a walking step with heel strike and leg swap (:mod:`problems.walking`),
the paper's periodic gait on a pinned foot (:mod:`problems.pinned`).
"""
