"""Kernel arguments as one unit: the arrays and constants an env's compiled kernels read.

An env's observation and step-and-observe kernels read a dozen or more arrays and constants
(states, parameter rows, references, noise, observation bounds, indices, outputs). They are
grouped once, in a numba ``StructRef`` whose fields are named, built by the batch when its
arrays change (:meth:`hydro_envs.envs.base.PlantBatch.observe_args`) and passed to every kernel
as one argument; a kernel reads ``a.Y``, ``a.REF``, ... by name. One field list per task
defines the unit; its order matters nowhere else.

A new task declares its unit in three lines::

    @structref.register
    class MyTaskArgsType(KernelArgsType): pass

    class MyTaskArgs(KernelArgs):
        fields = BATCH_FIELDS + ("REF", "e_scale")

    define_kernel_args(MyTaskArgs, MyTaskArgsType)

and builds it with ``MyTaskArgs.make({"Y": ..., ...})`` (a missing or extra name raises).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any, ClassVar

import numba
from numba.core import cgutils, types
from numba.experimental import structref
from numba.experimental.jitclass.base import imp_dtor
from numba.extending import intrinsic

from hydro_envs.sim.binding import function_instance

__all__ = ["BATCH_FIELDS", "KernelArgsType", "KernelArgs", "define_kernel_args"]

#: the fields every env's unit starts with: the batch's step arrays (states, plant inputs,
#: parameter rows, control period, sub-steps, RK4 work array, guard counts), step counts,
#: actions and outputs (:class:`hydro_envs.envs.base.PlantBatch`)
BATCH_FIELDS = ("Y", "U", "P", "dt", "NSUB", "W", "clamps", "K", "last_a", "prev_a", "obs", "reward")


class KernelArgsType(types.StructRef):
    """Numba type of a kernel-argument unit: its fields typed as given (literal ints and
    floats widened, so the unit's type does not depend on the values)."""

    def preprocess_fields(self, fields: Any) -> tuple[tuple[str, Any], ...]:
        return tuple((name, types.unliteral(t)) for name, t in fields)


@intrinsic
def _unit_from_tuple(typingctx: Any, unit_typeref: Any, values: Any) -> Any:
    """A new unit of type ``unit_typeref.instance_type`` holding the elements of the tuple
    ``values`` as its fields, in order (what numba's ``structref.new`` and one ``setattr`` per
    field do, as one intrinsic: compiled in milliseconds, where the proxy's generic constructor
    types 20-30 attribute stores and took about a second to compile in every new process)."""
    unit_type = unit_typeref.instance_type
    names = [name for name, _ in unit_type.field_dict.items()]
    field_types = [unit_type.field_dict[n] for n in names]

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        _, tup = args
        model = context.data_model_manager[unit_type.get_data_type()]
        alloc_type = model.get_value_type()
        meminfo = context.nrt.meminfo_alloc_dtor(
            builder, context.get_constant(types.uintp, context.get_abi_sizeof(alloc_type)),
            imp_dtor(context, builder.module, unit_type))
        data_pointer = builder.bitcast(context.nrt.meminfo_data(builder, meminfo), alloc_type.as_pointer())
        builder.store(cgutils.get_null_value(alloc_type), data_pointer)
        inst = context.make_helper(builder, unit_type)
        inst.meminfo = meminfo
        data = cgutils.create_struct_proxy(unit_type.get_data_type())(context, builder, ref=data_pointer)
        for k, (name, ft) in enumerate(zip(names, field_types)):
            val = context.cast(builder, builder.extract_value(tup, k), values.types[k], ft)
            context.nrt.incref(builder, ft, val)
            setattr(data, name, val)
        return inst._getvalue()

    if len(values.types) != len(names):
        raise TypeError(f"{unit_type}: {len(values.types)} values for {len(names)} fields")
    return unit_type(unit_typeref, values), codegen


def _new_unit(unit_typeref: Any, values: Any) -> Any:
    """The unit of type ``unit_typeref`` holding ``values`` (the template of each unit class's
    compiled constructor, :func:`_constructor`)."""
    return _unit_from_tuple(unit_typeref, values)  # type: ignore[call-arg]


def _constructor(proxy: type) -> Any:
    """``proxy``'s compiled constructor, cached on disk under a name of its own
    (``new_unit.<module>.<class>``): one shared constructor would keep every unit type it ever
    built in one cache index, and a process that cannot import one of those types (a unit
    defined in a test module) could not read the index at all."""
    name = re.sub(r"[^A-Za-z0-9_.]", "_", f"new_unit.{proxy.__module__}.{proxy.__qualname__}")
    return numba.njit(cache=True)(function_instance(_new_unit, name, "new_unit", _new_unit.__globals__))


class KernelArgs(structref.StructRefProxy):
    """Python side of a kernel-argument unit: built by :meth:`make`, passed to compiled kernels
    (directly or by :meth:`run`); its fields are read inside the kernels, not from Python."""

    fields: ClassVar[tuple[str, ...]] = ()
    #: the registered numba type class of the unit (set by :func:`define_kernel_args`)
    numba_type_class: ClassVar[type[KernelArgsType]]
    #: the unit's compiled constructor (set by :func:`define_kernel_args`, :func:`_constructor`)
    constructor: ClassVar[Any]

    @classmethod
    def make(cls, values: Mapping[str, Any]) -> KernelArgs:
        """The unit holding ``values`` (every field by name, nothing else)."""
        missing = [f for f in cls.fields if f not in values]
        extra = [k for k in values if k not in cls.fields]
        if missing or extra:
            raise ValueError(f"{cls.__name__}: missing fields {missing}, unknown fields {extra}")
        ordered = tuple(values[f] for f in cls.fields)
        unit_type = cls.numba_type_class([(f, numba.typeof(v)) for f, v in zip(cls.fields, ordered)])
        return cls.constructor(unit_type, ordered)  # type: ignore[no-any-return]

    def run(self, kernel: Any, *ints: int) -> None:
        """``kernel(self, *ints)`` for a compiled (``numba.njit``) kernel of this unit (and integer
        arguments, such as a block's bounds): after the first call, through the entry point numba
        compiled for the unit's type. The dispatcher types its arguments on every call (about
        1.3 us for a unit, a tenth of a single env's step); the entry point only unboxes them
        (0.2 us). The same compiled code runs either way."""
        entries = self.__dict__.setdefault("_entries", {})
        entry = entries.get(kernel)
        if entry is not None:
            entry(self, *ints)
            return
        kernel(self, *ints)  # compiles for these types, or picks the compiled version
        compiled = kernel.overloads.get((self._numba_type_,) + (types.int64,) * len(ints))
        entries[kernel] = compiled.entry_point if compiled is not None else kernel


def define_kernel_args(proxy: type[KernelArgs], numba_type: type[KernelArgsType]) -> None:
    """Bind ``proxy`` (fields in ``proxy.fields``) to its registered ``numba_type``."""
    structref.define_proxy(proxy, numba_type, list(proxy.fields))
    proxy.numba_type_class = numba_type
    proxy.constructor = _constructor(proxy)
