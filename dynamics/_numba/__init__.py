"""The one place where numba is configured: jit options, array views without reference counts, scratch memory
and the single-state calls from Python.  Every compiled function of the library is decorated with one of the
decorators below; no other module spells numba options.

Everything here is numba's public API: ``njit`` and its documented options, ``numba.carray``,
``numba.extending.intrinsic`` used as numba's own documentation uses it (an integer cast to a pointer, a stack
allocation through the IR builder numba hands an intrinsic, a struct read and written through
``cgutils.create_struct_proxy`` as in its extension guide's interval example), ``register_jitable``, and
``NumbaError``, the base of the errors a dispatcher raises (which :mod:`dynamics.checks` catches for an argument
it cannot type): this is the one module that imports ``numba.core``.  Nothing changes numba or Python's warnings
for the rest of the process.

* :data:`kernel`: cached to disk, GIL released, ``error_model="numpy"`` (no Python zero-division checks in
  the inner loops, which cost ~10x).  fastmath stays off: with strict IEEE arithmetic a state gives
  bit-identical results whether it is computed alone, in a batch or inside a simulation (reassociation would
  let each inlining context round differently).
* :data:`inline_kernel`: the same, inlined by numba into its caller (``inline="always"``).  For the small
  helpers called once per body (joint transforms, motion subspaces).
* :data:`generic_kernel`: not cached, for functions generic over a problem type (the ODE solvers): a cache
  index would pickle every problem type it saw (a test's ODE class too) and fail to load where that module is
  not importable.  They are compiled into a cached caller, whose cache holds the whole machine code.
* :data:`generic_inline`: a generic function inlined into its caller.
* :data:`helper`: numba's ``register_jitable``: a small function (the spatial algebra) compiled into each
  compiled caller, with no Python entry point or cache file of its own (those were most of a small kernel's
  compile and cache-load time); called from Python it runs as plain Python.

**Views without reference counts.**  Every array a compiled function holds is reference counted (an atomic
increment and decrement each time it is bound or passed).  :func:`float_at` and :func:`int_at` make arrays
with no owner over memory that someone else keeps alive (``numba.carray`` over a pointer): a packed model's
fields (:func:`dynamics.model._unpack`), a workspace carved from one flat buffer, a state's row.  They are
helpers, not inlined kernels: numba types a call to a helper once per signature, where it typed every inlined
copy again (an unpack of the contact record, 37 views: ~1.25 -> ~0.6 CPU s; LLVM inlines them all the same,
so the compiled code does the same work).  The rule: the
owner of the memory (the caller's array) outlives every view of it, and a view is never stored or returned.
:func:`borrow` gives such a view of an array, or of every array of a tuple, nested (one intrinsic that copies each
array's struct with the owner cleared: a simulation's problem of ~60 arrays compiles in well under a second,
against ~3.5 s for a function per member).  :func:`scratch` is scratch
memory for one kernel call: on that kernel's stack up to :data:`STACK_FLOATS`, else on the heap (end the
kernel with :func:`keep_alive` of it).

**Calls from Python.**  :class:`SingleCall` is a kernel compiled for one fixed signature (C-contiguous float64
states, the packed model), so numba's dispatcher refuses anything else (a list, float32, a strided array) and
the public function takes its general path, which checks and converts.  Kernels return a status
(:data:`DONE` or :data:`GENERAL`): they check lengths and finiteness themselves.

**Copies.** Compiled code copies arrays with :func:`copy_into`, not ``x[:] = y`` (whose shape check compiles
numba's error-message formatting in every function that has one).
"""

import numpy as np
from numba import carray, njit, types
from numba.core import cgutils
# NumbaError: what a dispatcher raises for an argument it cannot type (caught by dynamics.checks)
from numba.core.errors import NumbaError  # noqa: F401
from numba.extending import intrinsic, overload, register_jitable

JIT_OPTIONS = dict(cache=True, nogil=True, error_model="numpy")
GENERIC_OPTIONS = dict(nogil=True, error_model="numpy")

kernel = njit(**JIT_OPTIONS)
inline_kernel = njit(**JIT_OPTIONS, inline="always")
generic_kernel = njit(**GENERIC_OPTIONS)
generic_inline = njit(**GENERIC_OPTIONS, inline="always")
helper = register_jitable

#: status codes of the single-state kernels: done; take the general path (it raises the clear error, or
#: computes what the fast path does not handle)
DONE, GENERAL = 0, 1


def _pointer_intrinsic(dtype):
    """An intrinsic ``f(address) -> CPointer(dtype)``: numba's documented intrinsic example (an integer cast to
    a pointer), for one item type."""
    def typer(typingctx, address):
        if not isinstance(address, types.Integer):
            return None

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))
        return types.CPointer(dtype)(address), codegen
    typer.__name__ = f"_{dtype}_pointer"
    return intrinsic(typer)


_float_pointer = _pointer_intrinsic(types.float64)
_int_pointer = _pointer_intrinsic(types.int64)


@helper
def address(x):
    """The address of the first item of the array x (an integer)."""
    return x.ctypes.data


@helper
def float_at(base, start, shape):
    """The float64 array of ``shape`` (an int or a tuple) at item ``start`` of the 64-bit buffer whose first
    item is at address ``base``: C-contiguous, no owner (see the module docstring's rule)."""
    return carray(_float_pointer(base + 8 * start), shape)


@helper
def int_at(base, start, shape):
    """As :func:`float_at`, read as int64."""
    return carray(_int_pointer(base + 8 * start), shape)


@inline_kernel
def view(buf, start, shape):
    """``buf[start:start + prod(shape)].reshape(shape)`` of a C-contiguous 1-D float64 buffer, with no owner
    and unchecked: the caller keeps ``buf`` alive and in bounds."""
    return float_at(address(buf), start, shape)


def _viewable(ty):
    """Whether :func:`borrow` makes an owner-less view of an array of numba type ``ty``: C-contiguous, at least
    one dimension, items of a plain number type (records and other layouts keep numba's own handling)."""
    return (isinstance(ty, types.Array) and ty.layout == "C" and ty.ndim > 0
            and isinstance(ty.dtype, (types.Number, types.Boolean)))


def _view_type(ty):
    """The numba type of ``borrow(x)`` for ``x`` of type ``ty``: a view is a writable C array (as
    ``numba.carray`` makes one); a tuple's items are mapped, a NamedTuple keeps its class."""
    if _viewable(ty):
        return types.Array(ty.dtype, ty.ndim, "C")
    if isinstance(ty, types.BaseTuple) and len(ty) > 0:
        cls = ty.instance_class if isinstance(ty, types.BaseNamedTuple) else None
        return types.BaseTuple.from_types([_view_type(t) for t in ty], cls)
    return ty


def _lower_borrow(context, builder, ty, value):
    """The LLVM value of ``borrow(value)``: each viewable array's struct with no owner (null meminfo and
    parent: numba then counts no references, as for ``numba.carray``), tuples rebuilt item by item, anything else
    passed on with a reference of its own (the caller releases the result as a new reference)."""
    if _viewable(ty):
        ary = cgutils.create_struct_proxy(ty)(context, builder, value=value)
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        ary.parent = cgutils.get_null_value(ary.parent.type)
        return ary._getvalue()
    if isinstance(ty, types.BaseTuple) and len(ty) > 0:
        out = cgutils.get_null_value(context.get_value_type(_view_type(ty)))
        for k, item_ty in enumerate(ty):
            item = _lower_borrow(context, builder, item_ty, builder.extract_value(value, k))
            out = builder.insert_value(out, item, k)
        return out
    context.nrt.incref(builder, ty, value)
    return value


@intrinsic
def borrow(typingctx, x):
    """``borrow(x)`` in compiled code: ``x`` (an array, a tuple or NamedTuple of them, nested, or any other
    value) with every C-contiguous array of numbers replaced by an owner-less view of the same memory (the
    module docstring's rule: the caller keeps ``x`` alive and never stores or returns the result).  One
    intrinsic for the whole value: its code copies each array's struct with the owner cleared, so a problem of
    dozens of arrays costs one small function to compile, not one compiled or inlined function per member."""
    sig = _view_type(x)(x)

    def codegen(context, builder, signature, args):
        return _lower_borrow(context, builder, signature.args[0], args[0])
    return sig, codegen


#: scratch above this many floats (64 KiB) goes to the heap: threads may have small stacks (musl: 128 KiB)
STACK_FLOATS = 8192


@intrinsic
def _stack_pointer(typingctx, n):
    """n float64 on the stack of the function this is compiled into (the IR builder's ``alloca``)."""
    if not isinstance(n, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        return builder.alloca(context.get_value_type(types.float64), size=args[0])
    return types.CPointer(types.float64)(n), codegen


@inline_kernel
def stack_array(n):
    """n uninitialised float64 on the stack of the kernel that calls this (call it from the kernel itself or an
    :data:`inline_kernel`, never return it): free to allocate, freed when the kernel returns.  n <=
    :data:`STACK_FLOATS`."""
    return carray(_stack_pointer(n), n)


@inline_kernel
def scratch(n):
    """n floats of scratch for a kernel: :func:`stack_array` up to :data:`STACK_FLOATS`, else a heap array.
    Call it in the kernel that uses it (inlined, so the stack is that kernel's) and end with keep_alive."""
    return stack_array(n) if n <= STACK_FLOATS else np.empty(n)


@inline_kernel
def copy_into(dst, src):
    """dst[i] = src[i] for the n = len(dst) items of 1-D arrays (the caller keeps len(src) >= n).  In compiled
    code instead of ``dst[:] = src``: numba's array assignment compiles its shape-mismatch error with the
    message's string formatting (~2 s of a cold start), once in every function that has one."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


@helper
def keep_alive(x):
    """A use of ``x``: numba frees a variable after its last use, so this pins the owner of a borrowed value."""
    return None


#: the types of a single-state kernel's arguments: the packed model (read-only), states and results
PACKED = types.Array(types.int64, 1, "C", readonly=True)
VECTOR = types.float64[::1]
MATRIX = types.float64[:, ::1]


def single_signature(*args):
    """``int64(packed model, *args)``: a single-state kernel returns a status code."""
    return types.int64(PACKED, *args)


class SingleCall:
    """A single-state kernel (a plain function, compiled only here) compiled for one signature
    (:func:`single_signature`) on its first call, or loaded from the cache; from then on ``call`` *is* numba's
    dispatcher, so a call costs no Python frame of ours.  The dispatcher refuses any other argument type (a
    float32 or strided array, a list, a subclass: numba's documented ``TypeError``), and the public function
    then takes its general path, which checks and converts.  Only exact numpy arrays of the signature's types
    reach the kernel, which checks lengths and values itself and returns :data:`DONE` or :data:`GENERAL`."""

    def __init__(self, function, *argtypes):
        self.function, self.signature = function, single_signature(*argtypes)
        self.dispatcher = None

    def call(self, *args):
        self._refuse_before_compiling(args)
        self.dispatcher = njit(self.signature, **JIT_OPTIONS)(self.function)
        self.call = self.dispatcher
        return self.dispatcher(*args)

    def _refuse_before_compiling(self, args):
        """The first call: arguments the compiled dispatcher would refuse (not an exact ndarray of the
        signature's dtype and rank where it takes an array) raise its ``TypeError`` now, before the compilation:
        a first call with a list or a string takes the general path at once, not after seconds of compiling."""
        if len(args) != len(self.signature.args):
            raise TypeError(f"expected {len(self.signature.args)} arguments, got {len(args)}")
        for x, ty in zip(args, self.signature.args):
            if isinstance(ty, types.Array) and not (type(x) is np.ndarray and x.ndim == ty.ndim
                                                    and x.dtype == np.dtype(str(ty.dtype))):
                raise TypeError(f"not an exact {ty} array: {type(x).__name__}")

