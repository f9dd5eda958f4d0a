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
solver once (cached on disk): a first rk4 simulate from an empty cache ~17 CPU s against ~10 with the old
address boundary, a first auto ~28 against ~12 (benchmarks/sim_fixed_cost.py --cold), while the fixed cost of
a warm call fell from ~30 ms to ~0.4 ms.

The implementation is the attribute's ``py_func`` compiled by the overload itself, not a call to its
dispatcher: a wrapper calling the dispatcher would be one more compiled layer, and numba optimises each layer
again together with all the code it links in (the ABA).  Known cost: numba keys an overload's implementation by its caller's
flags, and a stepper's implementation is compiled without a Python wrapper while the entry point has one, so
``rhs`` is compiled twice per problem type (~2.5 of a first rk4 simulate's ~17 CPU s).

**Arrays without reference counts.**  numba counts the references of every array a compiled function binds,
an atomic increment and decrement each time: a right-hand side that reads the problem's tuples (the model's
tree, the ABA workspace, the torque source) paid ~2 us per evaluation for it on the 2R arm, four times the
arithmetic (with borrow: 0.7 us, against 0.5 us through the old address boundary).  Arrays with no owner (a
null meminfo, as ``numba.carray`` makes them) numba does not count.
:func:`borrow` (:mod:`dynamics._numba`) gives a problem (NamedTuples and tuples of arrays, nested) with every
C-contiguous array replaced by such a view of the same memory (writable in type: a kernel that must share the
run's compiled callees borrows its arguments too, :func:`dynamics.simulation.problem.singular_body`), once per
run at the entry point.
The rule: the borrowed value never outlives the call that made it (never stored or returned), and the caller
holds the original (the entry point's argument, held by its Python caller) meanwhile.

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


