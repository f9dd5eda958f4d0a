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
* :data:`borrowing_kernel`: a :data:`kernel` compiled without numba's reference counting (``_nrt=False``), for
  functions that only read and write the arrays they are given and allocate nothing (the simulation problem's
  functions, whose arrays are borrowed anyway, :func:`pack`): numba otherwise lowers an increment and a
  decrement of every array of every tuple it binds (the problem, its tree, the ABA workspace), a third of those
  functions' compile time.  An allocation in such a function is a compile error, not a leak.
* :data:`helper_kernel`: a :data:`kernel` that only compiled code calls (the spatial algebra's small
  functions): numba builds no Python or C wrapper for it.  Those wrappers were most of a small kernel's compile
  and cache-load time (a first rk4 simulate from an empty cache 11.6 -> 10.0 CPU s, import + first
  inverse_dynamics from a warm cache 2.2 -> 0.5 s).  Never call one from Python: it has no entry point there,
  and the interpreter would crash (the geometry functions Python code uses, such as ``rotation_log``, stay
  :data:`kernel`).

Kernels read the model's arrays into locals once at their top (``parents, mass = tree.parents, tree.mass``):
every array taken out of a tuple is reference counted with an atomic operation.

**Borrowed values.** :func:`borrowed` returns a value whose arrays have a NULL owner pointer (meminfo), so
numba's reference counting skips them.  The rule for using it safely: the caller keeps the owned original
alive (a later :func:`keep_alive` call on it), and the borrowed copy never outlives the call (never store or
return it).  It is used where a hot loop would otherwise pay tens of atomic increments per step.  :func:`view` makes
such borrowed arrays directly: a C-contiguous window of a flat buffer, with no checks and no reference count
(numba's own slice + reshape costs ~80 ns per view, which a single call from Python cannot afford); the same
rule applies to the buffer.  :func:`stack_array` is scratch on the kernel's own stack (a heap array costs
~0.2 us to allocate): never return it or keep it past the kernel that made it.

**Calls through an address.** :func:`pack` copies a value (a tuple of arrays, borrowed) into a buffer whose
address :func:`deref` reads back in a function compiled for ``types.CPointer`` of its type; :func:`native_address`
gives such a function's address and :func:`call_address` calls it from an intrinsic.  The simulation's solvers
call the problem this way (:mod:`dynamics.simulation.run`), so they compile without the problem's code, and the
problem calls its torque source this way (:func:`dynamics.torques.bind_source`); :func:`owned_pack` is a
:func:`pack` whose buffer keeps the packed value alive itself (so it can be stored in a problem's field).

**numba's inliner.** :func:`_deepcopy_scope` fixes a cost of numba's ``inline="always"`` (the copy of a
callee's IR grew as its blocks times its variables; tests/test_numba_inliner.py): the inlined kernels compile
~30% faster, same code.

**Copies.** Compiled code copies arrays with :func:`copy_into`, not ``x[:] = y`` (whose shape check compiles
numba's error-message formatting in every function that has one).

:class:`Kernel` calls a compiled function through its native entry point once its single overload exists,
skipping the dispatcher's type resolution (~4 us for a model's tuple of arrays).  :class:`Entry` does the same
for one fixed signature (:func:`single_signature`), the single-state entry points' way in (~60 ns per array).
:class:`PythonFunction` goes further for the shortest calls: a built-in function that reads numpy's array
headers itself and checks dtype and rank there too (section "Calls from Python without numba's wrapper").
"""

import copy
import ctypes
import struct
import sys
import threading

import numpy as np
from llvmlite import ir as llvm_ir
from numba import cfunc, njit, typeof, types
from numba.core import cgutils, ir
from numba.core.inline_closurecall import InlineWorker
from numba.core.registry import cpu_target
from numba.extending import intrinsic

_scope_copies = threading.local()


def _deepcopy_scope(self, memo):
    """``copy.deepcopy`` of an ``ir.Scope`` that, while numba inlines a function, copies each scope once.

    numba's ``InlineWorker.inline_ir`` deep-copies the callee's IR one block at a time, each with a fresh
    memo, so every block copies the function's whole scope again (every variable of the function): the cost
    grows as blocks x variables, and inlining our kernels' helpers took ~40% of their compile time.  During
    one ``inline_ir`` call this returns the first copy of a scope to every block, as the original IR shares one
    scope among its blocks."""
    shared = getattr(_scope_copies, "map", None)
    if shared is not None and id(self) in shared:
        out = shared[id(self)][1]
        memo[id(self)] = out
        return out
    out = ir.Scope.__new__(ir.Scope)
    memo[id(self)] = out
    if shared is not None:
        shared[id(self)] = (self, out)  # the original stays referenced, so its id is not reused
    for name, value in self.__dict__.items():
        out.__dict__[name] = copy.deepcopy(value, memo)
    return out


_numba_inline_ir = InlineWorker.inline_ir


def _inline_ir(self, *args, **kwargs):
    outer = getattr(_scope_copies, "map", None)
    _scope_copies.map = {}
    try:
        return _numba_inline_ir(self, *args, **kwargs)
    finally:
        _scope_copies.map = outer


if "__deepcopy__" not in vars(ir.Scope) and not hasattr(ir.Scope, "__slots__"):  # a numba that copies scopes
    ir.Scope.__deepcopy__ = _deepcopy_scope                                         # itself needs no help
    InlineWorker.inline_ir = _inline_ir

# _nrt=True explicitly: a function compiled while typing a borrowing_kernel's call would otherwise inherit its
# _nrt=False (numba passes the caller's flag to callees that do not set it) and keep that compilation
JIT_OPTIONS = dict(cache=True, nogil=True, error_model="numpy", _nrt=True)
GENERIC_OPTIONS = dict(nogil=True, error_model="numpy", _nrt=True)

kernel = njit(**JIT_OPTIONS)
inline_kernel = njit(**JIT_OPTIONS, inline="always")
generic_kernel = njit(**GENERIC_OPTIONS)
generic_inline = njit(**GENERIC_OPTIONS, inline="always")
gil_kernel = njit(cache=True, error_model="numpy", _nrt=True)
borrowing_kernel = njit(**dict(JIT_OPTIONS, _nrt=False))
helper_kernel = njit(**JIT_OPTIONS, no_cpython_wrapper=True, no_cfunc_wrapper=True)


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


def _dims(builder, context, shape_ty, shape):
    if isinstance(shape_ty, types.BaseTuple):
        return [context.cast(builder, d, t, types.intp) for d, t in zip(cgutils.unpack_tuple(builder, shape), shape_ty)]
    return [context.cast(builder, shape, shape_ty, types.intp)]


def _borrowed_array(context, builder, out_ty, data, dims):
    """A C-contiguous array of ``out_ty`` over ``data`` with a NULL owner (no reference counting)."""
    itemsize = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(out_ty.dtype)))
    strides, step = [], itemsize
    for d in reversed(dims):
        strides.insert(0, step)
        step = builder.mul(step, d)
    out = context.make_array(out_ty)(context, builder)
    data = builder.bitcast(data, out.data.type)
    context.populate_array(out, data=data, shape=dims, strides=strides, itemsize=itemsize,
                           meminfo=cgutils.get_null_value(out.meminfo.type))
    return out._getvalue()


def _view_typer(buf, start, shape, dtype):
    dims_ty = tuple(shape) if isinstance(shape, types.BaseTuple) else (shape,)
    if not (isinstance(buf, types.Array) and buf.ndim == 1 and buf.layout == "C" and buf.dtype.bitwidth == 64
            and isinstance(start, types.Integer) and all(isinstance(d, types.Integer) for d in dims_ty)):
        return None
    out_ty = types.Array(dtype or buf.dtype, len(dims_ty), "C", readonly=not buf.mutable)

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, args[0])
        first = context.cast(builder, args[1], sig.args[1], types.intp)
        dims = _dims(builder, context, sig.args[2], args[2])
        return _borrowed_array(context, builder, sig.return_type, builder.gep(src.data, [first]), dims)

    return out_ty(buf, start, shape), codegen


@intrinsic
def view(typingctx, buf, start, shape):
    """``buf[start:start + prod(shape)].reshape(shape)`` for a C-contiguous 1-D ``buf``, borrowed (NULL owner)
    and unchecked: the caller keeps ``buf`` alive and in bounds.  ``shape`` is an int or a tuple of ints."""
    return _view_typer(buf, start, shape, None)


@intrinsic
def float_view(typingctx, buf, start, shape):
    """:func:`view` of a 64-bit buffer read as float64 (the packed model keeps its floats in an int64 array)."""
    return _view_typer(buf, start, shape, types.float64)


@intrinsic
def int_view(typingctx, buf, start, shape):
    """:func:`view` of a 64-bit buffer read as int64 (integer scratch carved from a float buffer)."""
    return _view_typer(buf, start, shape, types.int64)


#: scratch above this many floats (64 KiB) goes to the heap: threads may have small stacks (musl: 128 KiB)
STACK_FLOATS = 8192


@intrinsic
def stack_array(typingctx, n):
    """n uninitialised float64 on the stack of the kernel that calls this (it must be called from the kernel
    itself or an ``inline_kernel``, never returned): free to allocate, freed when the kernel returns.  Keep n
    <= :data:`STACK_FLOATS`."""
    if not isinstance(n, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        size = context.cast(builder, args[0], sig.args[0], types.intp)
        data = builder.alloca(context.get_data_type(types.float64), size=size)
        return _borrowed_array(context, builder, sig.return_type, data, [size])

    return types.float64[::1](n), codegen


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


@helper_kernel
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


#: the types of a single-state kernel's arguments: the packed model (read-only), states and results
PACKED = types.Array(types.int64, 1, "C", readonly=True)
VECTOR = types.float64[::1]
MATRIX = types.float64[:, ::1]


def single_signature(*args):
    """``int64(packed model, *args)``: a single-state kernel returns a status code."""
    return types.int64(PACKED, *args)


class Entry:
    """A kernel's compiled entry point for one fixed signature: ``entry.call(*args)``.  The first call compiles
    it (or loads it from the cache) and replaces ``call`` by numba's entry point itself, so later calls cost
    one attribute lookup and the unboxing of the arguments.

    numba's entry point unboxes each argument in C but checks only an array's item size, not its dtype or
    rank: whoever calls it passes exactly the signature's types (an int64 array read as float64, or a 2-D
    array unboxed as 1-D, would be garbage or a crash); see :data:`dynamics.checks.F64`.
    """

    def __init__(self, dispatcher, signature):
        self.dispatcher, self.signature = dispatcher, signature

    def call(self, *args):
        self.call = self.dispatcher.compile(self.signature)
        return self.call(*args)


# ---------------------------------------------------------------------------------------------------
# Calls through an address (an opaque boundary for the compiler)
#
# numba links the code of every function a compiled function calls into it and optimises the whole again: a
# solver that calls the robot's right-hand side directly re-optimises the ABA and the torque source once per
# solver entry point.  The devices below let a caller hold a value of any type as a plain address
# (:func:`pack`, :func:`deref`) and call a compiled function through its address (:func:`call_address`), so
# the caller compiles without the callee's code and once for every problem type.  The rule: whoever holds
# the address keeps the packed value's owner (and the arrays it refers to) alive while the call runs.

@intrinsic
def _sizeof(typingctx, x):
    def codegen(context, builder, sig, args):
        return context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(sig.args[0])))
    return types.intp(x), codegen


@intrinsic
def _store(typingctx, buf, x):
    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        ptr = builder.bitcast(data, context.get_data_type(sig.args[1]).as_pointer())
        context.pack_value(builder, sig.args[1], _borrow_value(context, builder, sig.args[1], args[1]), ptr)
        return context.get_dummy_value()
    return types.none(buf, x), codegen


@kernel
def _pack_compiled(x):
    """:func:`pack` by numba itself, for a value holding a type :func:`_put` does not know."""
    buf = np.empty((_sizeof(x) + 7) // 8, np.int64)
    _store(buf, x)
    return buf


_SCALAR_FORMATS = {(types.Integer, 8): "b", (types.Integer, 16): "h", (types.Integer, 32): "i",
                   (types.Integer, 64): "q", (types.Float, 32): "f", (types.Float, 64): "d"}


def _put(mem, offset, ty, x):
    """Write x, of numba type ty, at ``offset`` of ``mem`` in numba's data layout (what ``context.pack_value``
    stores): an array as its struct {meminfo, parent, nitems, itemsize, data, shape, strides} with NULL owner
    and parent (borrowed), a tuple as the LLVM struct of its members (natural alignment), None as a NULL
    pointer.  Raises TypeError for another type."""
    ctx = _target_context()
    if isinstance(ty, types.Array):
        dims = list(x.shape) + list(x.strides)
        struct.pack_into(f"<5q{len(dims)}q", mem, offset, 0, 0, x.size, x.itemsize, x.ctypes.data, *dims)
    elif isinstance(ty, types.BaseTuple):
        for t, v in zip(ty, x):
            ll = ctx.get_data_type(t)
            align = ctx.get_abi_alignment(ll)
            offset = (offset + align - 1) // align * align
            _put(mem, offset, t, v)
            offset += ctx.get_abi_sizeof(ll)
    elif isinstance(ty, types.Boolean):
        struct.pack_into("<B", mem, offset, bool(x))
    elif isinstance(ty, types.NoneType):
        struct.pack_into("<q", mem, offset, 0)
    elif isinstance(ty, (types.Integer, types.Float)) and (type(ty), ty.bitwidth) in _SCALAR_FORMATS:
        fmt = _SCALAR_FORMATS[type(ty), ty.bitwidth]
        struct.pack_into("<" + (fmt.upper() if isinstance(ty, types.Integer) and not ty.signed else fmt), mem,
                         offset, x)
    else:
        raise TypeError(f"pack: no layout for {ty}")


def _target_context():
    return cpu_target.target_context  # created on first use


def pack(x):
    """A copy of the value ``x`` (a tuple of arrays and scalars, nested) in an int64 buffer, in numba's data
    layout, its arrays borrowed (NULL owner): ``buf.ctypes.data`` is a pointer :func:`deref` reads back.  Keep
    ``x`` alive while it is used.  Written from Python (no compiled function per value type: compiling one
    cost ~0.4 s of a cold start for each problem type); a type it does not know goes through numba's own
    ``pack_value``."""
    ty = typeof(x)
    ctx = _target_context()
    size = ctx.get_abi_sizeof(ctx.get_data_type(ty))
    buf = np.zeros((size + 7) // 8, np.int64)
    try:
        _put(memoryview(buf).cast("B"), 0, ty, x)
    except TypeError:
        return _pack_compiled(x)
    return buf


@intrinsic
def deref(typingctx, ptr):
    """The value a ``types.CPointer(T)`` argument points to (written by :func:`pack`); any other value is
    returned as it is, so one function serves a value and a pointer to it."""
    if not isinstance(ptr, types.CPointer):
        return ptr(ptr), lambda context, builder, sig, args: args[0]

    def codegen(context, builder, sig, args):
        return context.unpack_value(builder, sig.return_type, args[0])
    return ptr.dtype(ptr), codegen


class _Owner(bytearray):
    """The memory of an :func:`owned_pack` buffer, which also holds the packed value (``keep``)."""


def owned_pack(x):
    """:func:`pack` whose buffer keeps ``x`` alive itself (its memory is a bytearray holding a reference to x):
    the buffer can be stored (in a problem's field) and passed around without the rule's separate owner."""
    packed = pack(x)
    mem = _Owner(packed.nbytes)
    mem.keep = x
    buf = np.frombuffer(mem, np.int64)
    buf[:] = packed
    return buf


def native_address(dispatcher, signature):
    """The address of ``dispatcher``'s compiled function for ``signature`` (compiled, or loaded from the cache,
    now) in numba's native calling convention, for :func:`call_address`."""
    dispatcher.compile(signature)
    cres = dispatcher.overloads[tuple(signature.args)]
    return cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)


def call_address(context, builder, address, signature, args):
    """Lower a call of the function at ``address`` (an i64 from :func:`native_address`) whose numba signature
    is ``signature`` (the first argument a pointer: ``types.voidptr`` here, ``CPointer(T)`` in the callee);
    an exception raised by the callee propagates.  For intrinsics' codegen."""
    fnty = context.call_conv.get_function_type(signature.return_type, signature.args)
    fn = builder.inttoptr(address, fnty.as_pointer())
    status, out = context.call_conv.call_function(builder, fn, signature.return_type, signature.args, args)
    with cgutils.if_unlikely(builder, status.is_error):
        context.call_conv.return_status_propagate(builder, status)
    return out


def address_call(name, nargs):
    """An intrinsic ``call(fn, a0, .., a<nargs-1>)`` that calls the compiled function at address fn (an int64
    from :func:`native_address`) with these arguments and returns its result: the callee must be compiled for
    exactly the caller's argument types (or types of the same data layout), and its return type is taken from
    that compilation (``restype`` of :func:`address_signature`).  So a caller holds no copy of the callee's
    code: numba links every function a compiled function calls into it and optimises the whole again (the ABA
    costs ~0.5 s in each of its callers).  numba's intrinsics take a fixed number of arguments, hence the
    generated signature."""
    params = ", ".join(f"a{i}" for i in range(nargs))
    ns = {}
    exec(f"def {name}(typingctx, fn, restype, {params}):\n    return typer(fn, restype, ({params},))",
         {"typer": _address_call_typer}, ns)
    return intrinsic(ns[name])


def _address_call_typer(fn, restype, argtys):
    if not isinstance(fn, types.Integer) or not isinstance(restype, (types.NumberClass, types.TypeRef)):
        return None
    ret = restype.instance_type
    callee = ret(*argtys)

    def codegen(context, builder, sig, args):
        return call_address(context, builder, context.cast(builder, args[0], fn, types.int64), callee, args[2:])
    return ret(fn, restype, *argtys), codegen


# ---------------------------------------------------------------------------------------------------
# Calls from Python without numba's wrapper
#
# numba's entry point for a compiled function takes ~0.12 us for three arrays: each is wrapped in a fresh owner
# record (malloc, atomic counts, free), and the caller must check in Python what the wrapper does not (dtype and
# rank: ~0.05 us more).  For the shortest single-state calls (forward kinematics, a frame Jacobian: ~0.3 us of
# work) that is half the call.  :class:`PythonFunction` makes a built-in function of an entry (a Python
# function compiled as a ``cfunc`` of signature :data:`FASTCALL`: the arguments as CPython objects) that reads
# numpy's array header itself (PyArrayObject_fields: data, nd, dimensions, strides, descr, flags), checks what
# it needs in a few loads, and passes borrowed arrays (NULL owner) to the kernel: the caller's references keep
# them alive for the call.  The rule: an entry reads a field other than the type only after :func:`py_is_array`
# (or :func:`py_is_int`) said what the object is; anything it does not take gets the status GENERAL, never an
# error, and the public function takes its general path.

#: byte offsets in CPython (64-bit, default build) and numpy objects, checked by :class:`PythonFunction`
_OB_TYPE, _TUPLE_ITEMS = 8, 24
_ARRAY_DATA, _ARRAY_ND, _ARRAY_DIMS, _ARRAY_STRIDES, _ARRAY_DESCR, _ARRAY_FLAGS = 16, 24, 32, 40, 56, 64
#: in numpy's dtype object (PyArray_Descr, numpy 1 and 2): the byte-order character and the type number
_DESCR_BYTEORDER, _DESCR_TYPE_NUM = 26, 28
_NATIVE_ORDER = ord("<" if sys.byteorder == "little" else ">")
#: numpy's array flags
C_CONTIGUOUS, ALIGNED, WRITEABLE = 0x1, 0x100, 0x400
#: the slots of the tuple an entry gets as ``self``: its two status objects (DONE, GENERAL), then the types and
#: dtypes its checks compare with
SELF_NDARRAY, SELF_FLOAT64, SELF_INT64, SELF_INT = 2, 3, 4, 5
#: the signature of an entry (CPython's METH_FASTCALL): f(self, PyObject *const *args, Py_ssize_t nargs) -> PyObject *
FASTCALL = types.voidptr(types.voidptr, types.CPointer(types.voidptr), types.intp)
_I8P = llvm_ir.IntType(8).as_pointer()


def _field(context, builder, obj, offset, llty):
    """The value of type ``llty`` at byte ``offset`` (an i64 value or an int) of the object at ``obj``."""
    if isinstance(offset, int):
        offset = context.get_constant(types.intp, offset)
    if isinstance(obj.type, llvm_ir.IntType):  # an address held as an int64
        obj = builder.inttoptr(obj, _I8P)
    p = builder.gep(builder.bitcast(obj, _I8P), [offset])
    return builder.load(builder.bitcast(p, llty.as_pointer()))


def _py_reader(name, bits, extend):
    """An intrinsic ``name(obj, offset)``: the ``bits``-wide integer at byte ``offset`` of the object at ``obj``
    (a pointer or an address held as an int64), as int64 (``extend``: "sext" or "zext" below 64 bits)."""
    def typer(typingctx, obj, offset):
        def codegen(context, builder, sig, args):
            value = _field(context, builder, args[0], context.cast(builder, args[1], sig.args[1], types.intp),
                           llvm_ir.IntType(bits))
            return value if bits == 64 else getattr(builder, extend)(value, llvm_ir.IntType(64))
        return types.int64(obj, offset), codegen
    typer.__name__ = typer.__qualname__ = name
    return intrinsic(typer)


_py_word = _py_reader("_py_word", 64, None)  # an address, a size
_py_int32 = _py_reader("_py_int32", 32, "sext")
_py_byte = _py_reader("_py_byte", 8, "zext")


@intrinsic
def _py_item(typingctx, tup, k):
    """Item k of the tuple at ``tup`` (a borrowed reference)."""
    def codegen(context, builder, sig, args):
        k = context.cast(builder, args[1], sig.args[1], types.intp)
        offset = builder.add(context.get_constant(types.intp, _TUPLE_ITEMS),
                             builder.mul(k, context.get_constant(types.intp, 8)))
        return _field(context, builder, args[0], offset, _I8P)
    return types.voidptr(tup, k), codegen


@intrinsic
def py_int(typingctx, obj):
    """The value of the Python int at ``obj`` (``PyLong_AsLongLong``): only after :func:`py_is_int`, and for ints
    that fit (the entries' callers pass small ones)."""
    def codegen(context, builder, sig, args):
        i64 = llvm_ir.IntType(64)
        fn = cgutils.get_or_insert_function(builder.module, llvm_ir.FunctionType(i64, [_I8P]), "PyLong_AsLongLong")
        return builder.call(fn, [args[0]])
    return types.int64(obj), codegen


@intrinsic
def _py_new_ref(typingctx, obj):
    """obj with one more reference (``Py_IncRef``, which knows about immortal objects), to be returned."""
    def codegen(context, builder, sig, args):
        fn = cgutils.get_or_insert_function(builder.module, llvm_ir.FunctionType(llvm_ir.VoidType(), [_I8P]),
                                            "Py_IncRef")
        builder.call(fn, [args[0]])
        return args[0]
    return types.voidptr(obj), codegen


@intrinsic
def py_array(typingctx, obj, ty):
    """The numpy array at ``obj`` as a borrowed numba array of type ``ty`` (a TypeRef): its data, shape and
    strides read from the array's header.  Only after :func:`py_is_array` said yes for that rank and layout."""
    arr = ty.instance_type

    def codegen(context, builder, sig, args):
        intp = context.get_value_type(types.intp)
        dims = _field(context, builder, args[0], _ARRAY_DIMS, intp.as_pointer())
        strides = _field(context, builder, args[0], _ARRAY_STRIDES, intp.as_pointer())
        at = lambda p, k: builder.load(builder.gep(p, [context.get_constant(types.intp, k)]))  # noqa: E731
        out = context.make_array(arr)(context, builder)
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(arr.dtype)))
        context.populate_array(out, data=builder.bitcast(_field(context, builder, args[0], _ARRAY_DATA, _I8P),
                                                         out.data.type),
                               shape=[at(dims, k) for k in range(arr.ndim)],
                               strides=[at(strides, k) for k in range(arr.ndim)], itemsize=itemsize,
                               meminfo=cgutils.get_null_value(out.meminfo.type))
        return out._getvalue()

    return arr(obj, ty), codegen


@inline_kernel
def py_is_array(self, obj, dtype_slot, ndim, flags):
    """obj is exactly a numpy array (no subclass) of the dtype in slot ``dtype_slot`` of ``self``, of rank
    ``ndim``, with every one of ``flags`` set."""
    return (_py_word(obj, _OB_TYPE) == _py_word(self, _TUPLE_ITEMS + 8 * SELF_NDARRAY)
            and _same_dtype(_py_word(obj, _ARRAY_DESCR), _py_word(self, _TUPLE_ITEMS + 8 * dtype_slot))
            and _py_int32(obj, _ARRAY_ND) == ndim and (_py_int32(obj, _ARRAY_FLAGS) & flags) == flags)


@inline_kernel
def _same_dtype(descr, want):
    """The dtype object at ``descr`` is numpy's ``want`` itself or equal to it in native byte order (an array that
    came by pickle, from another process or a Ray task, has a dtype object of its own)."""
    return descr == want or (_py_int32(descr, _DESCR_TYPE_NUM) == _py_int32(want, _DESCR_TYPE_NUM)
                             and (_py_byte(descr, _DESCR_BYTEORDER) == _py_byte(want, _DESCR_BYTEORDER)
                                  or _py_byte(descr, _DESCR_BYTEORDER) == _NATIVE_ORDER))


@inline_kernel
def py_is_int(self, obj):
    """obj is exactly a Python int (then :func:`py_int` reads it)."""
    return _py_word(obj, _OB_TYPE) == _py_word(self, _TUPLE_ITEMS + 8 * SELF_INT)


@inline_kernel
def py_status(self, status):
    """The entry's result: its status object (``self[status]``) as a new reference."""
    return _py_new_ref(_py_item(self, status))


class _MethodDef(ctypes.Structure):
    _fields_ = [("ml_name", ctypes.c_char_p), ("ml_meth", ctypes.c_void_p), ("ml_flags", ctypes.c_int),
                ("ml_doc", ctypes.c_char_p)]


_METH_FASTCALL = 0x80
_new_function = ctypes.pythonapi.PyCFunction_NewEx
_new_function.restype = ctypes.py_object
_new_function.argtypes = [ctypes.c_void_p, ctypes.py_object, ctypes.py_object]


def _layout_is_known():
    """Whether the offsets above are this interpreter's and this numpy's (a probe array and tuple)."""
    a = np.zeros((2, 3))
    t = (a, 1)
    word = lambda x, k: ctypes.c_void_p.from_address(id(x) + k).value  # noqa: E731
    return (word(a, _OB_TYPE) == id(np.ndarray) and word(a, _ARRAY_DATA) == a.ctypes.data
            and ctypes.c_int.from_address(id(a) + _ARRAY_ND).value == 2 and word(a, _ARRAY_DESCR) == id(a.dtype)
            and ctypes.c_ssize_t.from_address(word(a, _ARRAY_STRIDES)).value == 24
            and ctypes.c_ssize_t.from_address(word(a, _ARRAY_DIMS) + 8).value == 3
            and ctypes.c_int.from_address(id(a) + _ARRAY_FLAGS).value & (C_CONTIGUOUS | WRITEABLE)
            == (C_CONTIGUOUS | WRITEABLE) and word(t, _TUPLE_ITEMS) == id(a) and word(t, _TUPLE_ITEMS + 8) == id(1)
            and all(ctypes.c_int.from_address(id(d) + _DESCR_TYPE_NUM).value == d.num
                    and ctypes.c_char.from_address(id(d) + _DESCR_BYTEORDER).value == d.byteorder.encode()
                    for d in (a.dtype, np.dtype(">f8"), np.dtype(np.int64))))


class PythonFunction:
    """``f.call(*args)`` calls ``entry`` (a module-level Python function written for :data:`FASTCALL`) compiled
    as a cfunc, directly: the first call compiles it (or loads it from the cache) and replaces ``call`` by a
    built-in function of it.  ``statuses`` = (DONE, GENERAL): the objects it returns (:func:`py_status`)."""

    def __init__(self, entry, statuses):
        self.entry, self.statuses = entry, statuses

    def call(self, *args):
        if not _layout_is_known():  # another interpreter build or numpy: every call takes the general path
            general = self.statuses[1]
            self.call = lambda *args: general
            return general
        try:  # a compile error must not look like one of the errors the callers catch (they take the general path)
            compiled = cfunc(FASTCALL, cache=True, error_model="numpy")(self.entry)
        except Exception as e:
            raise RuntimeError(f"compiling {self.entry.__qualname__}: {e}") from e
        method = _MethodDef(self.entry.__name__.encode(), compiled.address, _METH_FASTCALL, None)
        # the function's ``self`` holds what the entry compares with, and keeps the method record and the machine
        # code alive as long as the function itself (also if two threads made one each)
        owner = (*self.statuses, np.ndarray, np.dtype(np.float64), np.dtype(np.int64), int, method, compiled)
        self.call = _new_function(ctypes.addressof(method), owner, None)
        return self.call(*args)
