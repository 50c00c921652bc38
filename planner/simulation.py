"""One interval simulator: dynamics integrated over intervals on which the control is a polynomial.

Every re-integration of the project goes through :class:`Simulator`: the accuracy estimates
and the open-loop replay of a :class:`planner.Solution` (the transcription's own control
polynomial on each mesh interval) and ``problems.simulate`` (a torque profile represented by
a polynomial on each integration interval).

The dynamics are explicit, dx/dt = f(x, u, t), or a semi-explicit index-1 DAE,
dx/dt = f(x, z, u, t), 0 = r(x, z, u, t) (z algebraic: for the planner's generic implicit
residual, z = xdot). On an interval [t_a, t_a + h], with tau = (t - t_a) / h in [0, 1],
the control is u(tau) = C [1, tau, ..., tau^d] (C: (nu, d + 1) monomial coefficients, see
:func:`monomial_coefficients`), and an optional quadrature integrand q(x, z, u, t) is
integrated alongside (e.g. the power of the hinge torques).

Methods (CasADi integrator plugins): ``cvodes`` (BDF, ODE only) and ``idas`` (BDF, ODE or
DAE) honour rtol/atol; ``rk`` (fixed-step Runge-Kutta 4, ODE only) and ``collocation``
(Radau, fixed steps, ODE or DAE) use ``steps`` finite elements per interval.

* :meth:`Simulator.across`: independent intervals, each from its own initial state (one
  mapped call): the per-interval re-integration error of a solution.
* :meth:`Simulator.along`: one motion over a grid of intervals, each starting where the last
  ended. cvodes/idas run once over a block of intervals, stopping at every grid point so that
  each interval sees its own polynomial but keeping step size and order (unless
  ``restart``); one-step methods chain the interval integrator (``mapaccum``).

A failure raises :class:`SimulationError`, one line naming the method, the interval (located
by replaying the failed block interval by interval) and the SUNDIALS flag with what it means;
what CasADi and SUNDIALS write on stderr meanwhile is caught (:func:`captured_stderr`) and
kept in the error's ``details``.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import re
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from planner.errors import (
    AnthropoidError,
    DefinitionError,
    DefinitionTypeError,
    check_integer,
    check_real,
)

logger = logging.getLogger(__name__)

#: CasADi integrator plugins the simulator runs.
METHODS = ("cvodes", "idas", "rk", "collocation")
#: Methods that choose their own steps and honour rtol/atol.
VARIABLE_STEP = ("cvodes", "idas")
#: Methods that integrate a DAE (algebraic variables z).
DAE_METHODS = ("idas", "collocation")

#: Smallest rtol/atol accepted: a few hundred ulp of a unit angle. Below it cvodes and idas
#: stop with "too much accuracy requested" (measured on the six-link replay: 1e-15 still
#: runs, 1e-16 fails at the first step).
MIN_TOLERANCE = 1e-14

#: Most steps cvodes/idas take inside one interval before they give up.
MAX_NUM_STEPS = 100000

#: Intervals per integrator call in :meth:`Simulator.along`: a variable-step run restarts
#: once per block (for progress reports), a one-step chain is one CasADi call per block.
BLOCK_VARIABLE_STEP = 1000
BLOCK_FIXED_STEP = 200
#: Finite elements per call of a one-step chain (200 intervals of the default 8 steps): with
#: more steps per interval a block holds fewer intervals (at least one), so the progress
#: reports keep coming as often when a run is made finer (one-step methods keep no history:
#: the split changes nothing in the result).
BLOCK_FIXED_ELEMENTS = BLOCK_FIXED_STEP * 8


class SimulationError(AnthropoidError, RuntimeError):
    """The integrator failed (step-size underflow, too many steps, a non-finite state).

    The message is one line: the method, the time interval where it failed, the solver's flag
    with what it means, and what to change. Attributes: ``method``, ``interval`` ((t_a, t_b)
    s), ``index`` (of the interval in the call's grid, or None when the failure could not be
    pinned to one), ``flag`` (e.g. ``"CV_TOO_MUCH_WORK"``, or None) and ``details`` (what the
    integrator wrote on stderr while it failed, kept out of the terminal; also logged at DEBUG
    level).
    """

    def __init__(
        self,
        message: str,
        *,
        method: str | None = None,
        interval: tuple[float, float] | None = None,
        flag: str | None = None,
        details: str = "",
        index: int | None = None,
    ) -> None:
        super().__init__(message)
        self.method = method
        self.interval = interval
        self.flag = flag
        self.details = details
        self.index = index


# ---- tolerances -----------------------------------------------------------------------------
def tolerance_problem(value: float) -> str | None:
    """Why the finite ``value`` is no rtol/atol, and the fix; None when it is one.

    Shared by the library and the command line (``--rtol``/``--atol``), so they say the same.
    """
    if MIN_TOLERANCE <= value < 1:
        return None
    if value >= 1:
        fix = "give a tolerance such as 1e-10"
    elif value > 0:
        fix = (
            f"below {MIN_TOLERANCE:g} cvodes/idas cannot deliver the accuracy in double "
            "precision; give 1e-12 for a tight run"
        )
    else:
        fix = "a tolerance is a small positive number; give 1e-10, or 1e-12 for a tight run"
    return f"must lie in [{MIN_TOLERANCE:g}, 1), got {value!r}; {fix}"


def check_tolerance(name: str, value: object) -> float:
    """An integrator tolerance (rtol, atol): a real number in [MIN_TOLERANCE, 1)."""
    number = check_real(name, value)
    problem = tolerance_problem(number)
    if problem is not None:
        raise DefinitionError(f"`{name}`: {problem}")
    return number


# ---- quiet integrator calls ---------------------------------------------------------------
# One redirection of fd 2 at a time: two threads redirecting at once would restore each
# other's temporary file. Re-entrant, because a nested redirection restores correctly.
_STDERR_LOCK = threading.RLock()


@contextlib.contextmanager
def captured_stderr() -> Iterator[list[str]]:
    """Catch what CasADi and SUNDIALS write on stderr while the block runs.

    With ``disable_internal_warnings`` cvodes/idas stay quiet, but a failure inside a
    ``mapaccum`` still makes CasADi dump every input of the failing call (about 70 lines for
    six links), and no integrator option turns that off (casadi 3.8). CasADi's Python module
    writes through ``sys.stderr``, so that is swapped for a buffer; file descriptor 2 goes
    to a temporary file as well, for anything native code writes directly. Yields a list
    that receives the captured text when the block ends. Without a usable fd 2 (an
    embedding without one) only ``sys.stderr`` is swapped.
    """
    captured: list[str] = []
    buffer = io.StringIO()
    with _STDERR_LOCK:
        with contextlib.suppress(AttributeError, ValueError, OSError):
            sys.stderr.flush()  # text already written goes out before the switch
        try:
            saved = os.dup(2)
        except OSError:
            saved = None
        sink = tempfile.TemporaryFile() if saved is not None else None
        try:
            if sink is not None:
                os.dup2(sink.fileno(), 2)
            with contextlib.redirect_stderr(buffer):
                yield captured
        finally:
            text = buffer.getvalue()
            if sink is not None:
                os.dup2(saved, 2)
                os.close(saved)
                sink.seek(0)
                text += sink.read().decode("utf-8", errors="replace")
                sink.close()
            captured.append(text)


# ---- failures -----------------------------------------------------------------------------
#: SUNDIALS return flags of cvodes (CV_*) and idas (IDA_*): what they mean here, what to do.
_FLAG_ADVICE = {
    "TOO_MUCH_WORK": (
        f"more than {MAX_NUM_STEPS} steps inside one interval",
        "the motion diverges (torques too large, or an unstable motion run too long) or the "
        "tolerances are too tight for it; shorten t_span or loosen rtol/atol",
    ),
    "TOO_MUCH_ACC": (
        "the tolerances ask for more accuracy than double precision gives at this state",
        "loosen rtol/atol (1e-12 is safe)",
    ),
    "ERR_FAILURE": (
        "the error test failed repeatedly and the step size shrank to nothing",
        "the motion is singular or diverges here; shorten t_span or check the torques",
    ),
    "CONV_FAILURE": (
        "the Newton iteration failed repeatedly and the step size shrank to nothing",
        "the motion is singular or diverges here; shorten t_span or check the torques",
    ),
}
_FLAG_ADVICE["ERR_FAIL"] = _FLAG_ADVICE["ERR_FAILURE"]  # idas spelling
_FLAG_ADVICE["CONV_FAIL"] = _FLAG_ADVICE["CONV_FAILURE"]

#: What to change when the state of a fixed-step method (rk, collocation) blows up or an
#: implicit collocation step finds no solution.
_FIXED_STEP_ADVICE = (
    "the motion diverges (torques too large, or an unstable motion run too long) or the "
    "steps are too coarse for it; shorten t_span or raise steps"
)


def sundials_flag(error: Exception) -> str | None:
    """The SUNDIALS return flag (``CV_TOO_MUCH_WORK``, ``IDA_CONV_FAIL``, ...) in the text of
    a CasADi integrator exception, or None."""
    found = re.search(r'returned "([A-Z_]+)"', str(error))
    return found.group(1) if found else None


def _where(interval: tuple[float, float]) -> str:
    return f"between t = {interval[0]:.6g} s and t = {interval[1]:.6g} s"


def integrator_failure(
    method: str,
    interval: tuple[float, float],
    error: Exception,
    details: str,
    index: int | None = None,
) -> SimulationError:
    """One-line :class:`SimulationError` from a CasADi integrator exception."""
    text = str(error)
    flag = sundials_flag(error)
    if details:
        logger.debug("integrator %r wrote while failing:\n%s", method, details)
    where = _where(interval)
    if flag is not None:
        meaning, advice = _FLAG_ADVICE.get(
            flag.split("_", 1)[1], ("see the SUNDIALS documentation", "check the torques")
        )
        message = f"integrator {method!r} failed {where}: {flag} ({meaning}); {advice}"
    elif "rootfinder" in text:  # collocation: CasADi's "rootfinder process failed. Set ..."
        message = (
            f"integrator {method!r} failed {where}: the Newton iteration of an implicit "
            f"collocation step did not converge; {_FIXED_STEP_ADVICE}"
        )
    else:
        lines = [line for line in text.strip().splitlines() if line.strip()]
        last = lines[-1] if lines else type(error).__name__
        message = f"integrator {method!r} failed {where}: {last}"
    return SimulationError(
        message, method=method, interval=interval, flag=flag, details=details, index=index
    )


def _non_finite(
    method: str, interval: tuple[float, float], details: str, index: int | None
) -> SimulationError:
    """The error of a run that returned a NaN or inf state without raising (rk, collocation;
    CasADi only warns)."""
    advice = _FLAG_ADVICE["ERR_FAILURE"][1] if method in VARIABLE_STEP else _FIXED_STEP_ADVICE
    if details:
        logger.debug("integrator %r wrote while failing:\n%s", method, details)
    return SimulationError(
        f"integrator {method!r} failed {_where(interval)}: the state became non-finite; {advice}",
        method=method,
        interval=interval,
        details=details,
        index=index,
    )


# ---- control polynomials --------------------------------------------------------------------
def monomial_coefficients(points, values) -> np.ndarray:
    """Monomial coefficients of the polynomials through ``values`` at ``points``.

    Parameters
    ----------
    points : (m,) distinct tau in [0, 1] where the values are given.
    values : (K, m, nu) the control of K intervals at the points.

    Returns
    -------
    (K, nu, m) coefficients C with u(tau) = C [1, tau, ..., tau^(m-1)] on each interval
    (the layout :class:`Simulator` takes). Solving the Vandermonde system is accurate for
    m <= 10 points in [0, 1].
    """
    points = np.asarray(points, dtype=float)
    values = np.asarray(values, dtype=float)
    vandermonde = np.vander(points, points.size, increasing=True)  # V[i, k] = points[i]^k
    coefficients = np.linalg.solve(vandermonde[None], values)  # (K, m, nu)
    return np.transpose(coefficients, (0, 2, 1))


@dataclass(frozen=True)
class Run:
    """The result of :meth:`Simulator.along` or :meth:`Simulator.across`.

    states : (K, nx) state at each interval's end (``along``: with the initial state first,
        (M + 1, nx) over a grid of M intervals).
    algebraic : (K, nz) algebraic variables at the interval ends (``along``: (M + 1, nz), the
        first row the guess given), empty for an ODE.
    quadrature : (K, nq) integral of the quadrature integrand over each interval.
    """

    states: np.ndarray
    algebraic: np.ndarray
    quadrature: np.ndarray


class Simulator:
    """Integrates dx/dt = f(x, z, u, t), 0 = r(x, z, u, t) over intervals with polynomial
    controls (see the module docstring).

    Parameters
    ----------
    rate : casadi.Function (x (nx,), z (nz,), u (nu,), t (1,)) -> xdot (nx,).
    residual : casadi.Function (x, z, u, t) -> (nz,), or None for an ODE (nz = 0).
    quadrature : casadi.Function (x, z, u, t) -> (nq,) integrated over each interval, or None.
    degree : degree d >= 0 of the control polynomial on an interval.
    method : one of :data:`METHODS`; a DAE needs one of :data:`DAE_METHODS`.
    rtol, atol : tolerances of cvodes/idas in [MIN_TOLERANCE, 1) (ignored by rk, collocation).
    steps : finite elements per interval of rk and collocation (>= 1).

    The CasADi integrators are built on first use and kept: build one Simulator per model
    and options, and call it many times.
    """

    def __init__(
        self,
        rate: ca.Function,
        residual: ca.Function | None = None,
        quadrature: ca.Function | None = None,
        *,
        degree: int,
        method: str = "cvodes",
        rtol: float = 1e-10,
        atol: float = 1e-10,
        steps: int = 8,
    ) -> None:
        if method not in METHODS:
            raise DefinitionError(
                f"`method`: unknown integrator {method!r}; choose one of {METHODS}"
            )
        for name, function in (("rate", rate), ("residual", residual), ("quadrature", quadrature)):
            if function is not None and not isinstance(function, ca.Function):
                raise DefinitionTypeError(
                    f"`{name}`: must be a casadi.Function (x, z, u, t), got "
                    f"{type(function).__name__}"
                )
            if function is not None and function.n_in() != 4:
                raise DefinitionError(
                    f"`{name}`: must take the four inputs (x, z, u, t), got {function.name_in()}"
                )
        if residual is not None and residual.size1_out(0) and method not in DAE_METHODS:
            raise DefinitionError(
                f"`method`: {method!r} integrates ODEs only; a DAE (a residual with "
                f"algebraic variables) needs one of {DAE_METHODS}"
            )
        self.rate, self.residual, self.quadrature = rate, residual, quadrature
        self.degree = check_integer("degree", degree, 0)
        self.steps = check_integer("steps", steps, 1)
        self.method = method
        self.rtol = check_tolerance("rtol", rtol)
        self.atol = check_tolerance("atol", atol)
        self.nx = rate.size1_in(0)
        self.nz = rate.size1_in(1)
        self.nu = rate.size1_in(2)
        self.nq = quadrature.size1_out(0) if quadrature is not None else 0
        self._chains: dict[int, ca.Function] = {}

    @property
    def variable_step(self) -> bool:
        return self.method in VARIABLE_STEP

    @property
    def options(self) -> dict:
        """The CasADi integrator options: tolerances for cvodes/idas (SUNDIALS' own messages
        off: a failure becomes one SimulationError), finite elements for rk/collocation."""
        if self.variable_step:
            # The quadrature rides on the steps the states choose (no error control of its
            # own): turning it on changes the steps, and with them the replay of an unstable
            # motion, for no gain where the integrand is as smooth as the states.
            return {
                "abstol": self.atol,
                "reltol": self.rtol,
                "max_num_steps": MAX_NUM_STEPS,
                "disable_internal_warnings": True,
            }
        if self.method == "rk":
            return {"number_of_finite_elements": self.steps}
        return {"number_of_finite_elements": self.steps, "interpolation_order": 3}

    # ---- the model on one interval ----------------------------------------------------------
    def _dae(self, normalised: bool) -> dict:
        """The DAE on one interval with parameters [t_a; h; vec(C)] (C: (nu, d + 1)).

        ``normalised``: in tau in [0, 1] (dx/dtau = h f, the parameters as ``p``), else in
        physical time t with the parameters as piecewise-constant controls ``u`` (one column
        per interval of a grid run).
        """
        x, z = ca.SX.sym("x", self.nx), ca.SX.sym("z", self.nz)
        start, h = ca.SX.sym("t_a"), ca.SX.sym("h")
        coefficients = ca.SX.sym("c", self.nu, self.degree + 1)
        parameters = ca.vertcat(start, h, ca.vec(coefficients))
        time = ca.SX.sym("tau" if normalised else "t")
        tau = time if normalised else (time - start) / h
        t = start + h * time if normalised else time
        u = ca.mtimes(coefficients, ca.vertcat(*[tau**k for k in range(self.degree + 1)]))
        scale = h if normalised else 1
        dae = {
            "x": x,
            "t": time,
            "p" if normalised else "u": parameters,
            "ode": scale * self.rate(x, z, u, t),
        }
        if self.nz:
            dae["z"] = z
            dae["alg"] = self.residual(x, z, u, t)
        if self.quadrature is not None:
            dae["quad"] = scale * self.quadrature(x, z, u, t)
        return dae

    @cached_property
    def interval(self) -> ca.Function:
        """The integrator over one interval, tau from 0 to 1: (x0, z0, p = [t_a; h; vec(C)])
        -> (xf, zf, qf)."""
        return ca.integrator("interval", self.method, self._dae(True), 0.0, 1.0, self.options)

    @cached_property
    def _grid_dae(self) -> dict:
        return self._dae(False)

    def _chain(self, size: int) -> ca.Function:
        """``size`` intervals in one CasADi call (mapaccum feeds each xf to the next x0)."""
        if size not in self._chains:
            self._chains[size] = self.interval.mapaccum("chain", size)
        return self._chains[size]

    @staticmethod
    def parameters(starts, lengths, coefficients) -> np.ndarray:
        """(2 + nu (d + 1), K) integrator parameters [t_a; h; vec(C)] of K intervals from
        their starts (K,) s, lengths (K,) s and coefficients (K, nu, d + 1)."""
        starts = np.asarray(starts, dtype=float).reshape(-1)
        lengths = np.asarray(lengths, dtype=float).reshape(-1)
        coefficients = np.asarray(coefficients, dtype=float)
        # ca.vec is column-major over (nu, d + 1): entry (i, p) at p * nu + i.
        flat = np.transpose(coefficients, (0, 2, 1)).reshape(starts.size, -1)
        return np.vstack([starts[None, :], lengths[None, :], flat.T])

    # ---- calls ------------------------------------------------------------------------------
    def _call(self, function: ca.Function, arguments: dict) -> dict:
        result = function(**arguments)
        return {key: np.asarray(value) for key, value in result.items()}

    def _locate(self, x: np.ndarray, parameters: np.ndarray, z0: np.ndarray | None):
        """Index of the first interval of a failed block on which the integrator fails, when
        the block is replayed interval by interval from its initial state ``x``; None when
        every interval goes through (a variable-step run can fail where the restarted replay,
        with its different steps, does not)."""
        for k in range(parameters.shape[1]):
            arguments = {"x0": x, "p": parameters[:, k]}
            if self.nz:
                arguments["z0"] = z0[:, k]
            try:
                with captured_stderr():
                    result = self._call(self.interval, arguments)
            except RuntimeError:
                return k
            x = result["xf"].reshape(-1)
            if not np.all(np.isfinite(x)):
                return k
        return None

    def across(self, x0, parameters, z0=None) -> Run:
        """Independent intervals, each from its own initial state, in one mapped call.

        Parameters
        ----------
        x0 : (K, nx) initial states.
        parameters : (np, K) from :meth:`parameters`.
        z0 : (K, nz) guesses of the algebraic variables at each start (a DAE only).

        Returns a :class:`Run` with states (K, nx) at the interval ends. A failure raises
        :class:`SimulationError` naming the first interval that fails on its own.
        """
        x0 = np.asarray(x0, dtype=float).reshape(-1, self.nx)
        count = x0.shape[0]
        arguments = {"x0": x0.T, "p": parameters}
        if self.nz:
            arguments["z0"] = np.asarray(z0, dtype=float).reshape(count, self.nz).T
        try:
            with captured_stderr() as captured:
                result = self._call(self.interval.map(count), arguments)
        except RuntimeError as error:
            details = "".join(captured)
            for k in range(count):
                single = {key: value[:, k] for key, value in arguments.items()}
                try:
                    with captured_stderr():
                        self._call(self.interval, single)
                except RuntimeError as located:
                    raise integrator_failure(
                        self.method, _span(parameters, k), located, details, k
                    ) from error
            raise integrator_failure(
                self.method, (float(parameters[0, 0]), _end(parameters)), error, details
            ) from error
        states = result["xf"].T
        finite = np.all(np.isfinite(states), axis=1)
        if not np.all(finite):
            k = int(np.argmin(finite))
            raise _non_finite(self.method, _span(parameters, k), "".join(captured), k)
        return Run(states, result["zf"].T.reshape(count, self.nz), _quadrature(result, count))

    def along(
        self,
        x0,
        grid,
        coefficients,
        z0=None,
        *,
        restart: bool = False,
        progress: Callable[[float, float], None] | None = None,
    ) -> Run:
        """One motion over the intervals of ``grid``, each starting where the last ended.

        Parameters
        ----------
        x0 : (nx,) initial state at grid[0].
        grid : (M + 1,) s, strictly increasing interval ends.
        coefficients : (M, nu, d + 1) the control polynomial of each interval.
        z0 : (M, nz) guesses of the algebraic variables at each interval's start (a DAE).
        restart : cvodes/idas restart at every interval (as :meth:`across` does) instead of
            one run per block of intervals that keeps step size and order across them.
        progress : called after each block with (fraction of intervals done, time reached s).

        Returns a :class:`Run` with states (M + 1, nx) at the grid points (x0 first) and the
        quadrature of each interval (M, nq).

        One cvodes/idas run crosses a block of up to 1000 intervals, the polynomials as
        piecewise-constant controls: it stops at every grid point (so each interval sees its
        own polynomial, and a spline split at its knots is reproduced exactly) but keeps its
        step size and order: a restart at every interval is not needed for exactness, and it
        costs accuracy and time (each restart begins at first order with a tiny step and its
        own error budget). Measured on the paper22 replay with exact torques on a 1 ms grid:
        within 1e-6 rad for 0.30 s (restarts) vs 0.55 s (one run) at rtol = atol = 1e-10,
        0.49 s vs 0.62 s at 1e-12, and about ten times faster. One-step methods keep no
        history, so a restart costs nothing: one CasADi call per block of 200 intervals, or
        of fewer with more than 8 ``steps`` per interval (1600 finite elements per call, at
        least one interval), so that ``progress`` is called about as often.
        """
        grid = np.asarray(grid, dtype=float).reshape(-1)
        M = grid.size - 1
        x = np.asarray(x0, dtype=float).reshape(self.nx)
        h = np.diff(grid)
        parameters = self.parameters(grid[:-1], h, coefficients)
        guesses = None
        if self.nz:
            guesses = np.asarray(z0, dtype=float).reshape(M, self.nz).T
        one_run = self.variable_step and not restart
        if one_run:
            block = BLOCK_VARIABLE_STEP
        else:
            block = max(1, min(BLOCK_FIXED_STEP, BLOCK_FIXED_ELEMENTS // self.steps))
        states = np.empty((self.nx, M))
        algebraic = np.empty((self.nz, M))
        quadrature = np.empty((self.nq, M))
        done = 0
        while done < M:
            size = min(block, M - done)
            part = slice(done, done + size)
            try:
                with captured_stderr() as captured:
                    if one_run:
                        function = ca.integrator(
                            "simulation",
                            self.method,
                            self._grid_dae,
                            float(grid[done]),
                            grid[done + 1 : done + size + 1].tolist(),
                            self.options,
                        )
                        arguments = {"x0": x, "u": parameters[:, part]}
                        if self.nz:
                            arguments["z0"] = guesses[:, done]
                    else:
                        function = self._chain(size)
                        arguments = {"x0": x, "p": parameters[:, part]}
                        if self.nz:
                            arguments["z0"] = guesses[:, part]
                    result = self._call(function, arguments)
            except RuntimeError as error:
                failed = self._locate(
                    x, parameters[:, part], None if guesses is None else guesses[:, part]
                )
                if failed is None:  # the restarted replay went through: name the whole block
                    interval, index = (float(grid[done]), float(grid[done + size])), None
                else:
                    k = done + failed
                    interval, index = (float(grid[k]), float(grid[k + 1])), k
                raise integrator_failure(
                    self.method, interval, error, "".join(captured), index
                ) from error
            block_states = result["xf"].reshape(self.nx, size)
            finite = np.all(np.isfinite(block_states), axis=0)
            if not np.all(finite):  # rk, collocation: no error, a NaN (and CasADi's warnings)
                k = done + int(np.argmin(finite))
                raise _non_finite(
                    self.method, (float(grid[k]), float(grid[k + 1])), "".join(captured), k
                )
            if captured and captured[0].strip():
                logger.warning(
                    "integrator %r wrote on stderr: %s", self.method, captured[0].strip()
                )
            states[:, part] = block_states
            algebraic[:, part] = result["zf"].reshape(self.nz, size)
            if self.nq:
                total = result["qf"].reshape(self.nq, size)
                # One run integrates from the block's start; a chain per interval.
                quadrature[:, part] = np.diff(total, axis=1, prepend=0.0) if one_run else total
            x = block_states[:, -1]
            done += size
            if progress is not None:
                progress(done / M, float(grid[done]))
        first_z = guesses[:, :1] if self.nz else np.zeros((0, 1))
        return Run(
            np.concatenate([np.asarray(x0, dtype=float).reshape(self.nx, 1), states], axis=1).T,
            np.concatenate([first_z, algebraic], axis=1).T,
            quadrature.T,
        )

    def __repr__(self) -> str:
        kind = f"DAE nz={self.nz}" if self.nz else "ODE"
        accuracy = (
            f"rtol={self.rtol:g} atol={self.atol:g}"
            if self.variable_step
            else f"steps={self.steps}"
        )
        return (
            f"Simulator({self.method}, {kind}, nx={self.nx} nu={self.nu}, control degree "
            f"{self.degree}, {accuracy})"
        )


def _span(parameters: np.ndarray, k: int) -> tuple[float, float]:
    """(t_a, t_a + h) of interval k of an integrator parameter array."""
    return float(parameters[0, k]), float(parameters[0, k] + parameters[1, k])


def _end(parameters: np.ndarray) -> float:
    return float(np.max(parameters[0] + parameters[1]))


def _quadrature(result: dict, count: int) -> np.ndarray:
    quadrature = result.get("qf")
    if quadrature is None or quadrature.size == 0:
        return np.zeros((count, 0))
    return quadrature.reshape(-1, count).T


__all__ = [
    "DAE_METHODS",
    "METHODS",
    "MIN_TOLERANCE",
    "VARIABLE_STEP",
    "Run",
    "SimulationError",
    "Simulator",
    "captured_stderr",
    "check_tolerance",
    "integrator_failure",
    "monomial_coefficients",
    "sundials_flag",
    "tolerance_problem",
]
