"""The one place where numba is configured: jit options, the borrowed-array intrinsic and the fast caller.

Every compiled function of the library is decorated with one of the decorators below; no other module spells
numba options.

* :data:`kernel`: cached to disk, GIL released, ``error_model="numpy"`` (no Python zero-division checks in
  the inner loops, which cost ~10x).  fastmath stays off: with strict IEEE arithmetic a state gives
  bit-identical results whether it is computed alone, in a batch or inside a simulation (reassociation would
  let each inlining context round differently).
* :data:`inline_kernel`: the same, inlined by numba into its caller.  For the small helpers called once per
  body (joint transforms, motion subspaces): the arrays they read are then not reference counted per body
  (each count is an atomic operation: without inlining a 2-body RNEA costs 1.4 us instead of 0.3 us).
* :data:`generic_kernel`: not cached, for functions generic over a problem type (the ODE solvers): a cache
  index would pickle every problem type it saw (a test's ODE class too) and fail to load where that module is
  not importable.  They are compiled into a cached caller, whose cache holds the whole machine code.
* :data:`generic_inline`: a generic function inlined (numba IR) into its caller: the solver layers between a
  compiled entry point and the problem's right-hand side.  numba optimises each compiled function together
  with every function it calls (their code is linked in and optimised again), so each extra compiled layer
  above the ABA pays for optimising the ABA once more; inlined layers make one function per entry point.
* :data:`gil_kernel`: cached but holding the GIL, for the one function that calls back into Python.

Kernels read the model's arrays into locals once at their top (``parents, mass = tree.parents, tree.mass``):
every array taken out of a tuple is reference counted with an atomic operation.

**Borrowed values.** :func:`borrowed` returns a value whose arrays have a NULL owner pointer (meminfo), so
numba's reference counting skips them.  The rule for using it safely: the caller keeps the owned original
alive (a later :func:`keep_alive` call on it), and the borrowed copy never outlives the call (never store or
return it).  It is used where a hot loop would otherwise pay tens of atomic increments per step.

:class:`Kernel` calls a compiled function through its native entry point once its single overload exists,
skipping the dispatcher's type resolution (~4 us for a model's tuple of arrays).
"""

from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

JIT_OPTIONS = dict(cache=True, nogil=True, error_model="numpy")
GENERIC_OPTIONS = dict(nogil=True, error_model="numpy")

kernel = njit(**JIT_OPTIONS)
inline_kernel = njit(**JIT_OPTIONS, inline="always")
generic_kernel = njit(**GENERIC_OPTIONS)
generic_inline = njit(**GENERIC_OPTIONS, inline="always")
gil_kernel = njit(cache=True, error_model="numpy")


def _borrow_value(context, builder, ty, val):
    if isinstance(ty, types.Array):
        ary = context.make_array(ty)(context, builder, val)
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        ary.parent = cgutils.get_null_value(ary.parent.type)
        return ary._getvalue()
    if isinstance(ty, types.BaseTuple):
        for i, t in enumerate(ty):
            val = builder.insert_value(val, _borrow_value(context, builder, t, builder.extract_value(val, i)), i)
    return val


@intrinsic
def borrowed(typingctx, x):
    """``x`` (an array, or a tuple/namedtuple of arrays, nested) with every array's owner pointer set to NULL:
    same type, same data, but NRT_incref/NRT_decref on it return at once.  See the module docstring for the
    rule (keep the original alive with :func:`keep_alive`; never store or return the borrowed copy)."""
    def codegen(context, builder, sig, args):
        return _borrow_value(context, builder, sig.args[0], args[0])
    return x(x), codegen


@kernel
def keep_alive(x):
    """A use of ``x``: numba frees a variable after its last use, so this pins the owner of a borrowed value."""
    return None


class Kernel:
    """Call a numba function through its compiled entry point once it has been compiled.

    The public functions pass arguments whose types never vary (C-contiguous, writable float64 states, the
    model's read-only arrays), so after the first call the single compiled overload is called directly.  If
    a second overload ever appears, calls keep going through the dispatcher.
    """

    def __init__(self, dispatcher):
        self.dispatcher = dispatcher
        self.entry = None

    def __call__(self, *args):
        if self.entry is not None:
            return self.entry(*args)
        out = self.dispatcher(*args)
        overloads = list(self.dispatcher.overloads.values())
        if len(overloads) == 1:
            self.entry = overloads[0].entry_point
        return out
