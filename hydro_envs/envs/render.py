"""Dependency-free ``rgb_array`` frames: a cylinder sketch and a position/reference trace.

Drawn with numpy into an ``(H, W, 3)`` uint8 array, so rendering needs neither pygame nor
matplotlib (both optional). Top: the cylinder body, the piston at ``x``, the reference as a
red tick, chamber pressures as blue fill levels. Bottom: the last samples of reference (red)
and position (black) across the stroke.
"""

from __future__ import annotations

import numpy as np

__all__ = ["render_cylinder"]

WIDTH, HEIGHT = 480, 320


def _line(img: np.ndarray, xs: np.ndarray, ys: np.ndarray, color: tuple[int, int, int]) -> None:
    """Polyline through pixel coordinates (dense sampling, no anti-aliasing)."""
    if xs.size < 2:
        return
    n = int(max(np.abs(np.diff(xs)).sum(), np.abs(np.diff(ys)).sum())) + 2
    t = np.linspace(0.0, xs.size - 1, n)
    px = np.interp(t, np.arange(xs.size), xs).round().astype(int)
    py = np.interp(t, np.arange(ys.size), ys).round().astype(int)
    ok = (px >= 0) & (px < img.shape[1]) & (py >= 0) & (py < img.shape[0])
    img[py[ok], px[ok]] = color
    img[np.clip(py[ok] + 1, 0, img.shape[0] - 1), px[ok]] = color


def render_cylinder(
    x: float,
    reference: float,
    stroke: float,
    p1: float,
    p2: float,
    valve: float,
    history: np.ndarray,
) -> np.ndarray:
    """Frame for piston position ``x`` [m] of ``stroke``; pressures as fractions of supply."""
    img = np.full((HEIGHT, WIDTH, 3), 255, dtype=np.uint8)
    left, right, top, bot = 40, WIDTH - 40, 30, 110
    span = right - left

    def to_px(pos: float) -> int:
        return int(round(left + np.clip(pos / stroke, -0.05, 1.05) * span))

    xp = to_px(x)
    # chamber fills (pressure as height fraction), body outline, piston and rod
    for a, b, frac in ((left, xp, p1), (xp, right, p2)):
        h = int(np.clip(frac, 0.0, 1.0) * (bot - top))
        img[bot - h : bot, min(a, b) : max(a, b)] = (170, 200, 255)
    img[top : top + 3, left:right] = 60
    img[bot - 3 : bot, left:right] = 60
    img[top:bot, left : left + 3] = 60
    img[top:bot, right - 3 : right] = 60
    img[top - 10 : bot + 10, max(xp - 4, 0) : xp + 4] = 30
    mid = (top + bot) // 2
    img[mid - 4 : mid + 4, 0:left] = 90
    img[mid - 4 : mid + 4, right:WIDTH] = 90
    rp = to_px(reference)
    img[top - 20 : top - 2, max(rp - 2, 0) : rp + 2] = (220, 30, 30)
    # valve command bar
    vc = WIDTH // 2
    vw = int(np.clip(valve, -1.0, 1.0) * 100)
    img[bot + 18 : bot + 26, min(vc, vc + vw) : max(vc, vc + vw) + 1] = (40, 160, 40)
    img[bot + 14 : bot + 30, vc] = 0
    # trace panel
    t0, t1 = bot + 45, HEIGHT - 10
    img[t0, left:right] = 200
    img[t1, left:right] = 200
    if history.size:
        n = history.shape[0]
        xs = np.linspace(left, right - 1, max(n, 2))[:n]
        for col, color in ((0, (220, 30, 30)), (1, (0, 0, 0))):
            ys = t1 - np.clip(history[:, col] / stroke, 0.0, 1.0) * (t1 - t0)
            _line(img, xs, ys, color)
    return img
