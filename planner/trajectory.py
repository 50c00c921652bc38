"""The project's one sampled-trajectory / torque-profile type.

CONTRACT (fixed; the implementation is filled in by the trajectory work, used by
planner.Solution and by problems.torques_along / problems.simulate):

    Trajectory(
        time:      (K,) float, s, strictly increasing
        states:    (K, nx) float
        controls:  (K, nu) float
        state_names, state_units:     tuple[str, ...] of length nx
        control_names, control_units: tuple[str, ...] of length nu
        extras:    dict[str, (values (K,), unit str)]   derived channels (ddpsi_*, Fx, Fy, ...)
        metadata:  dict, JSON-serialisable (source, model parameters, transcription, N,
                   status, cost, package versions, ...)
    )

Linkage naming convention (used by planner for a model.Dynamics and by problems):
    states   psi_<link> [rad] for every link, then dpsi_<link> [rad/s]
    controls M_<link>   [N m]  (hinge torques)
    extras   ddpsi_<link> [rad/s^2], Fx [N], Fy [N] (ground reaction at H0) when known

    Trajectory.from_linkage(time, psi, dpsi, torques, names, ddpsi=None,
                            ground_reaction=None, metadata=None)   -> Trajectory
    .psi, .dpsi, .torques, .ddpsi (K, n) and .link_names   (raise if not a linkage trajectory)
    .at(t) -> (states (len(t), nx), controls (len(t), nu))   piecewise-cubic interpolation
            (states: cubic Hermite using the derivative channels when present, else natural
            cubic spline; controls: natural cubic spline), numpy only
    .control_function(kind="cubic"|"linear") -> callable t -> (nu,) or (K, nu)
    .resample(rate_hz=None, times=None) -> Trajectory
    .save(path, rate_hz=None)   format by suffix: .csv, .json, .npz; full precision; atomic
                                write (temporary file + os.replace): nothing half-written
    Trajectory.load(path) -> Trajectory   (each format reads back what save wrote)
    .plot(...) -> matplotlib Figure (states and controls against time); stick figures and
                  GIF animations for linkages live in planner.plots and take a model.Dynamics
"""
