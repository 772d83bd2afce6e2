"""The graphical Stribeck construction of 004 sec. 3.1 (the seed's own route to its Table 2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


from identification.friction.data import InsufficientDataError, UnidentifiableError

__all__ = ['GraphicalStribeck', 'graphical_stribeck']


# ======================================================================================
# graphical construction (004 sec. 3.1)
# ======================================================================================


@dataclass
class GraphicalStribeck:
    """Result of the graphical Stribeck construction of 004 sec. 3.1 (one direction).

    ``F_s`` intercept of the low-speed line f1 (slope ``-k``), ``F_c`` and ``sigma`` intercept
    and slope of the high-speed line f2, ``v_s`` where f1 meets the horizontal ``F = F_c``.
    """

    F_s: float
    F_c: float
    v_s: float
    sigma: float
    k: float
    split_speed: float
    n_low: int
    n_high: int

    @property
    def parameters(self) -> dict[str, float]:
        return {"F_c": self.F_c, "F_s": self.F_s, "v_s": self.v_s, "F_v": self.sigma}


def graphical_stribeck(
    v: Any,
    force: Any,
    *,
    low_speed_max: float | None = None,
    high_speed_min: float | None = None,
) -> GraphicalStribeck:
    """The graphical construction of 004 sec. 3.1 / Fig. 3 on one direction's points.

    004's recipe: the low-speed part of the friction curve is approximately a line f1 with
    slope ``-k`` whose ordinate intercept is ``F_s``; the high-speed part is a line f2 with
    slope ``sigma`` and intercept ``F_c``; the horizontal line through ``F_c`` meets the
    low-speed line at the critical Stribeck velocity, ``v_s = (F_s - F_c) / k``. (The text
    says the horizontal line meets "the curve"; for a curve above ``F_c + sigma v`` everywhere,
    as 002 eq (1) is, only the low-speed line f1 can be meant.) Works on speeds ``|v|`` and
    magnitudes ``|F|``.

    ``low_speed_max`` / ``high_speed_min`` [m/s] pick the points of each line; without them the
    split speed minimising the total squared error of the two lines is used (at least 3 points
    per line).

    For the exponential model 002 eq (1), the tangent at 0 has slope
    ``k = (F_s - F_c) / v_s - sigma``; if f1 were that tangent the construction would return
    ``v_s (F_s - F_c) / (F_s - F_c - sigma v_s)`` (5.3 % high at 004 Table 2). A chord through
    points spread over the dip is flatter than the tangent: ``F_s`` comes out low and ``v_s``
    high (tests quantify it). ``F_c`` and ``sigma`` are unbiased once the high-speed points lie
    beyond about 5 ``v_s``.
    """
    s = np.abs(np.asarray(v, dtype=float))
    f = np.abs(np.asarray(force, dtype=float))
    if s.shape != f.shape or s.ndim != 1:
        raise ValueError("v and force must be 1-D of equal length")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(f))):
        raise ValueError("v and force must be finite")
    order = np.argsort(s)
    s, f = s[order], f[order]
    n = s.size
    if n < 6:
        raise InsufficientDataError(
            f"the graphical construction needs at least 6 points (3 per line), got {n}"
        )

    def line(mask):
        a = np.column_stack([np.ones(int(mask.sum())), s[mask]])
        coef, *_ = np.linalg.lstsq(a, f[mask], rcond=None)
        sse = float(np.sum((a @ coef - f[mask]) ** 2))
        return coef, sse

    if low_speed_max is None and high_speed_min is None:
        best = None
        for i in range(3, n - 2):
            lo = np.arange(n) < i
            if np.unique(s[lo]).size < 2 or np.unique(s[~lo]).size < 2:
                continue
            c1, e1 = line(lo)
            c2, e2 = line(~lo)
            if best is None or e1 + e2 < best[0]:
                best = (e1 + e2, lo, ~lo, 0.5 * (s[i - 1] + s[i]))
        if best is None:
            raise InsufficientDataError("too few distinct speeds for two lines")
        _, low, high, split = best
    else:
        low = s <= (low_speed_max if low_speed_max is not None else high_speed_min)
        high = s >= (high_speed_min if high_speed_min is not None else low_speed_max)
        split = float(low_speed_max if low_speed_max is not None else high_speed_min)
        for nm, m in (("low-speed", low), ("high-speed", high)):
            if m.sum() < 2 or np.unique(s[m]).size < 2:
                raise InsufficientDataError(f"the {nm} line needs at least 2 distinct speeds")
    (f_s, slope1), _ = line(low)
    (f_c, sigma), _ = line(high)
    k = -slope1
    if not k > 0:
        raise UnidentifiableError(
            ["F_s", "v_s"],
            "the low-speed points do not fall with speed (slope "
            f"{slope1:.4g} N s/m): no Stribeck dip, F_s and v_s are unidentifiable",
        )
    v_s = (f_s - f_c) / k
    if not v_s > 0:
        raise UnidentifiableError(
            ["v_s"], f"F_s = {f_s:.4g} N is not above F_c = {f_c:.4g} N: v_s is unidentifiable"
        )
    return GraphicalStribeck(
        F_s=float(f_s), F_c=float(f_c), v_s=float(v_s), sigma=float(sigma), k=float(k),
        split_speed=float(split), n_low=int(low.sum()), n_high=int(high.sum()),
    )


