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

from collections.abc import Mapping
from typing import Any, ClassVar

from numba.core import types
from numba.experimental import structref

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


class KernelArgs(structref.StructRefProxy):
    """Python side of a kernel-argument unit: built by :meth:`make`, passed to compiled kernels
    (directly or by :meth:`run`); its fields are read inside the kernels, not from Python."""

    fields: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def make(cls, values: Mapping[str, Any]) -> KernelArgs:
        """The unit holding ``values`` (every field by name, nothing else)."""
        missing = [f for f in cls.fields if f not in values]
        extra = [k for k in values if k not in cls.fields]
        if missing or extra:
            raise ValueError(f"{cls.__name__}: missing fields {missing}, unknown fields {extra}")
        return cls(*(values[f] for f in cls.fields))

    def run(self, kernel: Any) -> None:
        """``kernel(self)`` for a compiled (``numba.njit``) kernel of this unit: after the first
        call, through the entry point numba compiled for the unit's type. The dispatcher types
        its argument on every call (about 1.3 us for a unit, a tenth of a single env's step);
        the entry point only unboxes it (0.2 us). The same compiled code runs either way."""
        entries = self.__dict__.setdefault("_entries", {})
        entry = entries.get(kernel)
        if entry is not None:
            entry(self)
            return
        kernel(self)  # compiles for this unit's type, or picks the compiled version
        compiled = kernel.overloads.get((self._numba_type_,))
        entries[kernel] = compiled.entry_point if compiled is not None else kernel


def define_kernel_args(proxy: type[KernelArgs], numba_type: type[KernelArgsType]) -> None:
    """Bind ``proxy`` (fields in ``proxy.fields``) to its registered ``numba_type``."""
    structref.define_proxy(proxy, numba_type, list(proxy.fields))
