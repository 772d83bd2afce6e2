r"""Figures of a benchmark result: metric box plots and the traces of draw 0.

Readable as printed: 1300 px wide (13 in at 100 dpi), every font 9 pt or larger, at most
:data:`MAX_LINES` lines per axes (the traces of more controllers go to further rows), and a
unit on every axis (``[-]`` for ratios and fractions; the box plots' horizontal axis names the
controllers).

* ``<stem>_box.png``: one panel per metric with finite values, one box per controller
  (episodes); a logarithmic axis when the boxes span more than a factor 30.
* ``<stem>_traces.png``: per row up to ``MAX_LINES - 1`` controllers: output and reference
  (left), tracking error ``reference - output`` (right), over time. An error peak more than three
  times the row's median peak (an open-loop baseline) runs off the error panel's scale, and its
  legend entry says so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["DPI", "FONT", "MAX_LINES", "WIDTH_IN", "box_figure", "metric_unit", "trace_figure", "write_figures"]

WIDTH_IN = 13.0
DPI = 100
MAX_LINES = 5
#: matplotlib font sizes [pt]
FONT = {"font.size": 10, "axes.titlesize": 11, "axes.labelsize": 10, "xtick.labelsize": 9,
        "ytick.labelsize": 9, "legend.fontsize": 9, "figure.titlesize": 12}

#: metric -> unit; ``None``: the tracked quantity's unit
_UNITS = {"rmse": None, "max_error": None, "reversal_error": None, "reversal_excess": None,
          "steady_state_error": None, "limit_cycle": None, "hunting": None, "cvar10_rmse": None,
          "friction_share": "-", "overshoot": "%", "settling_time": "s", "effort": "-",
          "pressure_violations": "steps", "endstop_steps": "steps", "stick_time": "-", "failed": "-",
          "rmse_rel_pid": "-"}


def metric_unit(key: str, quantity_unit: str) -> str:
    """Unit of a benchmark metric (``quantity_unit`` for the errors of the tracked quantity)."""
    u = _UNITS.get(key, "-")
    return quantity_unit if u is None else u


def _strip_unit(label: str) -> str:
    """A metric label without a trailing ``[...]`` (the axis label adds the unit)."""
    return label.split(" [")[0] if label.endswith("]") else label


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def box_figure(res: Any, metrics: Sequence[tuple[str, str]], quantity_unit: str):
    """Box plots of the per-episode ``metrics`` (``(key, label)``) of every controller."""
    plt = _plt()
    names = list(res.episodes)
    keys = [(k, lab) for k, lab in metrics
            if any(k in d and np.isfinite(d[k]).any() for d in res.episodes.values())]
    cols = 3
    rows = max(1, math.ceil(len(keys) / cols))
    with plt.rc_context(FONT):
        fig, axes = plt.subplots(rows, cols, figsize=(WIDTH_IN, 3.6 * rows), squeeze=False,
                                 layout="constrained")
        for ax, (k, lab) in zip(axes.ravel(), keys):
            data = []
            for c in names:
                v = np.asarray(res.episodes[c].get(k, np.zeros(0)), dtype=float)
                data.append(v[np.isfinite(v)])
            ax.boxplot([d if d.size else [np.nan] for d in data], showfliers=True)
            ax.set_xticks(range(1, len(names) + 1), names, rotation=20, ha="right")
            pos = np.concatenate([d[d > 0] for d in data] + [np.zeros(0)])
            if pos.size and all(d.size == 0 or d.min() > 0 for d in data) and pos.max() > 30 * pos.min():
                ax.set_yscale("log")
            ax.set_title(_strip_unit(lab))
            ax.set_ylabel(f"{_strip_unit(lab)} [{metric_unit(k, quantity_unit)}]")
            ax.set_xlabel("controller")
            ax.grid(True, axis="y", alpha=0.3)
        for ax in axes.ravel()[len(keys):]:
            ax.axis("off")
        fig.suptitle(f"{res.env_id} ({res.params}, n = {res.n} draws)")
    return fig


def trace_figure(res: Any, quantity: str, quantity_unit: str):
    """Output, reference and error over time of draw 0, ``MAX_LINES - 1`` controllers a row."""
    plt = _plt()
    names = list(res.traces)
    per = MAX_LINES - 1
    groups = [names[i : i + per] for i in range(0, len(names), per)] or [[]]
    y0, ref = next(iter(res.traces.values())) if names else (np.zeros(1), np.zeros(1))
    t = res.dt * np.arange(1, ref.size + 1)
    with plt.rc_context(FONT):
        fig, axes = plt.subplots(len(groups), 2, figsize=(WIDTH_IN, 3.4 * len(groups)), squeeze=False,
                                 layout="constrained")
        for (ax_y, ax_e), group in zip(axes, groups):
            ax_y.plot(t, ref, "k--", lw=1.2, label="reference")
            errors = {c: res.traces[c][1] - res.traces[c][0] for c in group}
            clipped = _outliers(errors)
            for c in group:
                ax_y.plot(t, res.traces[c][0], lw=1.0, label=c)
                ax_e.plot(t, errors[c], lw=1.0, label=c + (" (off scale)" if c in clipped else ""))
            kept = [np.max(np.abs(e[np.isfinite(e)]), initial=0.0) for c, e in errors.items() if c not in clipped]
            if clipped and max(kept, default=0.0) > 0:
                ax_e.set_ylim(-1.15 * max(kept), 1.15 * max(kept))
            ax_y.set_ylabel(f"{quantity} [{quantity_unit}]")
            ax_e.set_ylabel(f"error (reference - {quantity}) [{quantity_unit}]")
            for ax in (ax_y, ax_e):
                ax.set_xlabel("time [s]")
                ax.grid(True, alpha=0.3)
                ax.legend(loc="best")
        axes[0, 0].set_title(f"draw 0, episode seed {res.seed}: output and reference")
        axes[0, 1].set_title("tracking error")
        fig.suptitle(f"{res.env_id} ({res.params})")
    return fig


def _outliers(errors: dict[str, np.ndarray], factor: float = 3.0) -> set[str]:
    """Controllers whose peak |error| exceeds ``factor`` x the median peak of the group: left off
    the error panel's scale so the others stay readable (e.g. the open-loop ``zero``)."""
    peaks = {c: float(np.max(np.abs(e[np.isfinite(e)]), initial=0.0)) for c, e in errors.items()}
    if len(peaks) < 2:
        return set()
    med = float(np.median(list(peaks.values())))
    return {c for c, p in peaks.items() if med > 0 and p > factor * med}


def write_figures(res: Any, out_dir: Path, stem: str, metrics: Sequence[tuple[str, str]], quantity: str,
                  quantity_unit: str, stage: Any = None) -> list[Path]:
    """Write ``<stem>_box.png`` and ``<stem>_traces.png`` to ``out_dir``; their paths. With
    ``stage`` (a :class:`hydro_envs.outputs.Staged` of ``out_dir``) they are written to its
    temporary files and committed with the rest of the result; else each file atomically."""
    from hydro_envs.outputs import atomic_path

    plt = _plt()
    out = []
    for suffix, fig in (("box", box_figure(res, metrics, quantity_unit)),
                        ("traces", trace_figure(res, quantity, quantity_unit))):
        path = Path(out_dir) / f"{stem}_{suffix}.png"
        try:
            if stage is not None:
                fig.savefig(stage.path(path.name), dpi=DPI)
            else:
                with atomic_path(path) as tmp:
                    fig.savefig(tmp, dpi=DPI)
        finally:
            plt.close(fig)
        out.append(path)
    return out
