"""Two CPU instructions numba does not expose, as intrinsics for compiled code.

* :func:`prefetch_row_element` asks the CPU to load the cache line of ``a[i, j]`` of a 2-D array
  ahead of its use (LLVM's ``llvm.prefetch``: a hint, no fault, no effect on any result). The
  shaking table's observation reads each copy's 6-s reference at the step and five previews
  ahead, every copy in a different 48 kB row; stepping to the next sample, every eighth step of
  each stream enters a new cache line, and the misses stalled each observation.
* :func:`cpu_pause` is x86's ``pause``, the instruction an idle OpenMP worker waits with
  (:mod:`hydro_envs._spin` times it).
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["prefetch_row_element", "cpu_pause"]


@intrinsic
def prefetch_row_element(typingctx, a, i, j):
    """Prefetch the cache line holding ``a[i, j]`` (2-D array, in-bounds indices) for reading."""
    if not (isinstance(a, types.Array) and a.ndim == 2 and isinstance(i, types.Integer)
            and isinstance(j, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        aryty = sig.args[0]
        arr = context.make_array(aryty)(context, builder, args[0])
        idx = [context.cast(builder, args[1], sig.args[1], types.intp),
               context.cast(builder, args[2], sig.args[2], types.intp)]
        ptr = cgutils.get_item_pointer(context, builder, aryty, arr, idx, wraparound=False)
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            "llvm.prefetch.p0")
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(0), i32(3), i32(1)])  # read, keep in all levels, data
        return context.get_dummy_value()

    return types.none(a, i, j), codegen


@intrinsic
def cpu_pause(typingctx):
    """The x86 ``pause`` instruction (``llvm.x86.sse2.pause``; x86-64 only)."""

    def codegen(context, builder, sig, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), []), "llvm.x86.sse2.pause")
        builder.call(fn, [])
        return context.get_dummy_value()

    return types.none(), codegen
