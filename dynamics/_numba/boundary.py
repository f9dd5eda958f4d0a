"""How the simulation's compiled code reaches the problem, the stepper and the torque source: numba's public
API only (``overload``, ``njit``).

**Interface calls.**  The solvers are generic over a problem type and a stepper type, both NamedTuple classes
that carry their njit functions as class attributes (``RobotProblem.rhs``; :mod:`dynamics.simulation.solvers.
interface`).  :func:`interface_call` makes a function ``call(obj, ...)`` that, in compiled code, runs
``type(obj).<name>(obj, ...)``: an ``overload`` whose implementation is that class attribute's Python function,
found at compile time from the argument's type.  So the solver, the problem (the ABA, the torque source) and
the stepper compile into one entry point per method and problem type, cached by numba as one machine-code
object (:mod:`dynamics.simulation.run`).  No addresses, no hand-written layouts, no private call convention:
the price is that each problem type (each torque kind, constrained or not) compiles its own copy of a method's
solver once (cached on disk; measured in the simulation's README section and benchmarks/sim_fixed_cost.py).

The implementation is the attribute's ``py_func`` compiled by the overload itself, not a call to its
dispatcher: a wrapper calling the dispatcher would be one more compiled layer, and numba optimises each layer
again together with all the code it links in (the ABA).

**Python from compiled code.**  :data:`python_kernel` is a cached kernel that holds the GIL (``nogil=False``
spelled out), for the one function that calls back into Python through ``numba.objmode`` (a Python-callable
torque): numba warns about an object-mode block in a function that would release the GIL, and we do not
silence warnings for the process.
"""

from numba import njit
from numba.extending import overload

from . import JIT_OPTIONS

#: options of the interface calls' implementations (the caller's entry point is the cached unit)
_IMPL_OPTIONS = {k: v for k, v in JIT_OPTIONS.items() if k in ("nogil", "error_model")}

python_kernel = njit(cache=True, error_model="numpy", nogil=False)


def interface_call(name, params):
    """A function ``name(obj, ...)`` that compiled code calls as ``type(obj).<name>(obj, ...)`` (module
    docstring).  ``params``: every parameter name, ``obj``'s first, as the attributes spell them (numba checks
    that an overload's implementation has the stub's parameter names).  From Python it raises
    NotImplementedError."""
    args = ", ".join(params)
    ns = {}
    # numba matches an overload by the stub's parameter names, so the stub is written out with them
    exec(f"def {name}({args}):\n    raise NotImplementedError('{name}: compiled code only')", ns)
    stub = ns[name]
    stub.__doc__ = f"``type({params[0]}).{name}({args})`` in compiled code (an interface call)."

    def typer(obj, *rest):
        cls = getattr(obj, "instance_class", None)
        fn = getattr(cls, name, None)
        if fn is None:
            return None  # numba then says no implementation matches, naming the type
        return getattr(fn, "py_func", fn)

    exec(f"def _typer_{name}({args}):\n    return typer({args})", {"typer": typer}, ns)
    overload(stub, jit_options=_IMPL_OPTIONS)(ns[f"_typer_{name}"])
    return stub
