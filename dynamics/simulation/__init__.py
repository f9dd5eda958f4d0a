"""Forward simulation with an honest report: :func:`simulate` returns a :class:`Trajectory`.

==================  =====================================================================================
module              what it holds
==================  =====================================================================================
``simulate``        the public entry: checks -> one run in the core -> report
``simulator``       :class:`Simulator`: environments stepped one control period at a time from the caller's loop
``native``          one run in the C++ core (``core/simulation/``: the problems, the methods, the drivers)
``report``          status, switches, error estimate, energy balance, contact
``sensitivities``   what ``sensitivities=`` asks for (the variational equations are the core's)
``solvers``         the methods' names, options, statistics and switch records
==================  =====================================================================================
"""

from .report import state_error
from .simulate import INTEGRATORS, OUTPUTS, Trajectory, simulate
from .simulator import Simulator

__all__ = ["simulate", "Simulator", "Trajectory", "state_error", "INTEGRATORS", "OUTPUTS"]
