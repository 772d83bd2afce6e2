"""Plain-JSON conversion used by every command and result of the project (``to_jsonable``).

Results carry numpy arrays and scalars, tuples and non-finite floats; ``json.dumps`` accepts
none of them strictly. :func:`to_jsonable` maps them to plain JSON types. It imports nothing:
an object can only be a numpy one if numpy has been imported already, so the light command
line (``hydro --help``) stays free of numpy.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from typing import Any

__all__ = ["to_jsonable"]


def to_jsonable(obj: Any) -> Any:
    """``obj`` as plain JSON types.

    Mappings become dicts with string keys, lists/tuples/sets lists, numpy arrays nested lists,
    numpy scalars Python scalars; non-finite floats become None (JSON has no NaN/inf); strings,
    bools, ints and None stay; anything else becomes its ``str()``.
    """
    np = sys.modules.get("numpy")
    if np is not None:
        if isinstance(obj, np.ndarray):
            return to_jsonable(obj.tolist())
        if isinstance(obj, np.generic):
            obj = obj.item()
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [to_jsonable(v) for v in obj]
    return str(obj)
