"""The command line: ``python -m problems`` (console script ``anthropoid-planner``).

One module per command, each with ``add_parser`` and ``run``:

    walk        plan a walking step (the main job): torques for the drives, files, plots,
                and with --feedback the closed loop (problems.cli.walk)
    study       a walking study: walking steps over a grid of values, resumable
                (problems.cli.study)
    equations   print the equations of motion of a preset linkage, as text or LaTeX
    torques     first problem of dynamics: torques along a gait law, written to files and plots
    simulate    second problem of dynamics: integrate the motion under the torques of a file
    demo        the six-link equations of motion and the gait-law torque table

:mod:`problems.cli.program` builds the parser and dispatches; :mod:`problems.cli.common` holds
the output layer, option types and limits the commands share; :mod:`problems.cli.output_set`
writes a command's folder as one set.

The command line is the project's output layer: it alone prints. Results go to stdout,
progress and errors to stderr (including the planner's iterations, which
``planner.solve(progress=True)`` logs on ``planner.progress``: shown by default, ``--quiet``
turns them off); a bad input gives one line "anthropoid-planner <command>: error: ..." and
exit status 2; a failed computation (the library's own errors, such as a SimulationError) or a
file that cannot be written, one line and exit status 1. Only the library's errors and OSError
are caught: anything else is a bug and keeps its traceback. A command creates its output
folder only when it has results to write (walk: a converged, verified gait), so a run that
fails leaves nothing on disk. Commands that could run for long or write large files refuse
beyond LIMIT_SAMPLES samples (or about LIMIT_SECONDS of fixed-step integration) unless given
--force, and beyond MAX_SAMPLES always.
"""

from problems.cli.program import COMMANDS, build_parser, main

__all__ = ["COMMANDS", "build_parser", "main"]
