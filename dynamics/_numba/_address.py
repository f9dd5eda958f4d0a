"""TEMPORARY: the simulation's calls through an address, on numba's internals (being replaced by a public-API
boundary; issue 22).  Nothing else may import this module."""

import struct

import numpy as np
from numba import njit, typeof, types
from numba.core import cgutils
from numba.core.registry import cpu_target
from numba.extending import intrinsic

from . import JIT_OPTIONS, kernel

borrowing_kernel = kernel  # was _nrt=False (private): callees inherited it and could not allocate


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


