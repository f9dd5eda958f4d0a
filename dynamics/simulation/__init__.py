"""Forward simulation with an honest report: :func:`simulate` returns a :class:`Trajectory`.

==================  =====================================================================================
module              what it holds
==================  =====================================================================================
``simulate``        the public entry: checks -> problem -> run -> report
``problem``         the robot as an ODE (state layout, right-hand side, samples), by named fields
``run``             one compiled entry point per method, the stability probe, the first-compile message
``report``          status, switches, error estimate, energy balance
``solvers/``        one file per method (tableau, one attempted step, dense output) and the two drivers
==================  =====================================================================================
"""

from .report import state_error
from .simulate import INTEGRATORS, OUTPUTS, Trajectory, simulate

__all__ = ["simulate", "Trajectory", "state_error", "INTEGRATORS", "OUTPUTS"]
