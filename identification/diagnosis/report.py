"""Human-readable diagnosis report: markdown plus PNG figures (matplotlib, Agg).

``report.md`` holds the verdict and its reason, the noise floor per channel and the held-out
residual after each step (channel units and floors), where a mismatch above the floor remains,
the effects found with their parameters and the held-out
NRMSE before/after, the final model (every fitted parameter with its standard error, bounds
flagged), every round's candidate table (signature score, held-out NRMSE, gain,
plausibility, identifiability, reasons) and the notes; the figures are the residual maps of
the base and the final model (RMS weighted residual binned by velocity, position, pressure
difference and command, each axis in its unit), the residual spectrum and time traces of
held-out windows (measured and final model; the residual of the base and the final model).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from identification.diagnosis.plants import DiagnosisPlant
from identification.diagnosis.records import Record
from identification.diagnosis.fitting import _simulate
from identification.diagnosis.residuals import residual_maps
from identification.diagnosis.workflow import DiagnosisResult

__all__ = ["write_report"]


def _feature_units(spec: DiagnosisPlant) -> dict[str, str]:
    """SI unit of each residual-map feature (the x axes of the maps)."""
    pos = spec.units.get(spec.position_channel, "")
    return {"velocity": f"{pos}/s" if pos else "", "position": pos, "pressure_difference": "Pa",
            "command": spec.units.get(spec.inputs[0], "") if spec.inputs else ""}


def _fig_maps(path: Path, before: dict, after: dict, spec: DiagnosisPlant) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    feats = [k for k in ("velocity", "position", "pressure_difference", "command") if k in before]
    chans = list(before[feats[0]]["rms"]) if feats else []
    units = _feature_units(spec)
    fig, axes = plt.subplots(len(chans), len(feats), figsize=(3.2 * len(feats), 2.4 * len(chans)), squeeze=False)
    for j, f in enumerate(feats):
        for i, c in enumerate(chans):
            ax = axes[i, j]
            ax.plot(before[f]["bin_centres"], before[f]["rms"][c], "o-", color="C0", label="base model")
            if f in after:
                ax.plot(after[f]["bin_centres"], after[f]["rms"][c], "s--", color="C3", mfc="none",
                        label="final model")
            ax.set_xlabel(f"{f.replace('_', ' ')} [{units.get(f) or '-'}]")
            ax.set_ylabel(f"RMS residual {c} [noise std]")
            ax.grid(alpha=0.3)
    if chans and feats:
        axes[0, 0].legend(fontsize=7)
    fig.suptitle("Residual maps: where the model disagrees (in units of the channel's noise)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _fig_spectrum(path: Path, before: dict, after: dict) -> None:
    import matplotlib.pyplot as plt

    spec_b = before.get("frequency", {})
    fig, ax = plt.subplots(figsize=(6, 3.2))
    for c, d in spec_b.items():
        line, = ax.loglog(d["frequency"][1:], d["residual_over_measured"][1:], label=f"{c} base")
        if c in after.get("frequency", {}):
            da = after["frequency"][c]
            ax.loglog(da["frequency"][1:], da["residual_over_measured"][1:], ":", lw=2, color=line.get_color(),
                      label=f"{c} final")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("residual PSD / measured PSD [-]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _fig_traces(path: Path, res: DiagnosisResult, spec: DiagnosisPlant, records: Sequence[Record]) -> None:
    """Per channel two rows: the signal (measured, final model) and the residual of the base
    and the final model (measured - model), where the two models differ visibly even when
    both signals lie on the measured one."""
    import matplotlib.pyplot as plt

    sims = _simulate(spec, [res.base_model, res.final_model], records)
    (exps, base_out), (exps_f, fin_out) = sims
    n = min(3, len(exps))
    chans = list(base_out[0])
    fig, axes = plt.subplots(2 * len(chans), n, figsize=(3.6 * n, 1.9 * 2 * len(chans)), squeeze=False,
                             sharex="col")
    for j in range(n):
        e = exps[j]
        t = e.dt * np.arange(e.n_samples)
        has_final = j < len(fin_out) and exps_f[j].n_samples == e.n_samples
        for i, c in enumerate(chans):
            unit = spec.units.get(c, "") or "-"
            ax, ax_r = axes[2 * i, j], axes[2 * i + 1, j]
            ax.plot(t, e.outputs[c], "k.", ms=1.5, label="measured")
            ax.plot(t, (fin_out[j] if has_final else base_out[j])[c], color="C3", lw=1,
                    label="final model" if has_final else "base model")
            ax.set_ylabel(f"{c} [{unit}]")
            ax_r.plot(t, e.outputs[c] - base_out[j][c], color="C0", lw=1, label="base model")
            if has_final:
                ax_r.plot(t, e.outputs[c] - fin_out[j][c], "--", color="C3", lw=1, label="final model")
            ax_r.set_ylabel(f"residual {c} [{unit}]")
            ax_r.grid(alpha=0.3)
        axes[0, j].set_title(f"window {e.name}", fontsize=7)
        axes[-1, j].set_xlabel("t [s]")
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    fig.suptitle("Held-out windows (free run from the measured start state)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _final_model_section(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown table of the final model (:mod:`identification.diagnosis.final_model`)."""
    if not rows:
        return []
    lines = ["## Final model", "", "Every parameter of the last fit (standard error from its covariance); a "
             "parameter on a bound of its fit is flagged.", "",
             "| parameter | belongs to | value | std. error | unit | bounds | on a bound |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['name']} | {r['role']} | {r['value']:.4g} | {r['std_error']:.2g} | {r['unit']} | "
                     f"[{r['lower']:.4g}, {r['upper']:.4g}] | {'**yes**' if r['on_bound'] else 'no'} |")
    return lines + [""]


def _floor_section(res: DiagnosisResult) -> list[str]:
    """The noise floor per channel (its parts, the estimator and the verdict's threshold) and
    the held-out residual after each step, in channel units and floors."""
    if not res.noise_floor:
        return []
    lines: list[str] = []
    lines += ["## Noise floor and held-out residual", "",
              "Noise floor per channel (estimated from the held-out data: white sensor noise inside the score "
              "band, plus the spread the noise of measured inputs causes); verdict `unexplained` above the "
              "threshold column: factor x floor, the factor twice the residual a correct model is expected to "
              "leave on this record (noise, start-state error from noise and mains lines, the lines' in-band "
              f"part) x its noise spread, at least the plant's {res.unexplained_factor:g} floors."
              + "".join(f" Noise levels: {v['estimator']}." for v in list(res.noise_floor.values())[:1]
                        if v.get("estimator")), "",
              "| channel | unit | sensor noise | in score band | from input noise | floor | start state | "
              "mains lines | expected [floors] | spread | factor [floors] | threshold |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for k, v in res.noise_floor.items():
        fac = v.get("factor", res.unexplained_factor)
        hz = f" ({', '.join(f'{f:g}' for f in v['lines_hz'])} Hz)" if v.get("lines_hz") else ""
        lines.append(f"| {k} | {v['unit']} | {v['sensor_noise']:.3g} | {v['sensor']:.3g} | {v['input']:.3g} "
                     f"| {v['floor']:.3g} | {v.get('start_state', float('nan')):.3g} | {v.get('lines', float('nan')):.3g}{hz} "
                     f"| {v.get('expected', float('nan')):.3g} | {v.get('spread', float('nan')):.3g} | {fac:.3g} "
                     f"| {v.get('threshold', fac * v['floor']):.3g} |")
    lines += ["", "| step | " + " | ".join(f"{k} RMS [{v['unit']}] (floors)" for k, v in res.noise_floor.items())
              + " |", "|---|" + "---|" * len(res.noise_floor)]
    for r in res.residual:
        lines.append(f"| {r['step']} | " + " | ".join(
            f"{r['rms'].get(k, float('nan')):.3g} ({r['floors'].get(k, float('nan')):.2f})" for k in res.noise_floor)
            + " |")
    lines.append("")
    return lines


def write_report(res: DiagnosisResult, spec: DiagnosisPlant, records: Sequence[Record],
                 holdout: Sequence[Record] | None, out_dir: str | Path) -> Path:
    """Write ``report.md``, ``result.json`` and the figures into ``out_dir``; return the
    markdown path. The files are committed together (:class:`hydro_envs.outputs.Staged`): a
    failed write (a full disk) leaves none of them."""
    from hydro_envs.outputs import Staged

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with Staged(out) as stage:
        return _write_report(stage, res, spec, records, holdout, out)


def _write_report(stage: Any, res: DiagnosisResult, spec: DiagnosisPlant, records: Sequence[Record],
                  holdout: Sequence[Record] | None, out: Path) -> Path:
    data = list(records)
    before = residual_maps(spec, res.base_model, data, res.sigma)
    after = residual_maps(spec, res.final_model, data, res.sigma)
    figs = {}
    try:
        _fig_maps(stage.path("residual_maps.png"), before, after, spec)
        _fig_spectrum(stage.path("residual_spectrum.png"), before, after)
        _fig_traces(stage.path("traces.png"), res, spec, list(holdout) if holdout else data)
        figs = {"residual maps": "residual_maps.png", "residual spectrum": "residual_spectrum.png",
                "held-out traces": "traces.png"}
    except ImportError:  # matplotlib is an optional extra
        stage.discard()
    lines = [f"# Diagnosis of `{res.plant}`", "", f"**Verdict: {res.verdict}**"
             + (f" ({res.ambiguous})" if res.ambiguous else ""), ""]
    if res.reason:
        lines += [f"Reason: {res.reason}", ""]
    lines.append("Base-model fit: " + ", ".join(f"{k} = {v:.4g}" for k, v in res.base_fit.items()))
    lines.append("")
    lines += _floor_section(res)
    if res.mismatch:
        m = res.mismatch
        lines += [f"Where the mismatch remains: channel `{m['channel']}` ({m['ratio']:.1f} floors); by operating "
                  "region (median speed {:.3g} {}): ".format(m["median_speed"], m.get("speed_unit", "")) + ", ".join(
                      f"{k} {v['rms']:.3g} {m['unit']} ({v['floors']:.1f} floors)" for k, v in m["regions"].items())
                  + "; share of the residual power above the noise by band: " + ", ".join(
                      f"{k} {v:.0%}" for k, v in m["bands"].items()), ""]
    if res.effects:
        lines += ["## Effects found (in order)", "", "| effect | parameters | held-out NRMSE before | after | shrink (channels) |",
                  "|---|---|---|---|---|"]
        for e in res.effects:
            ps = "; ".join(f"{k} = {v:.4g} +- {e['std_errors'].get(k, float('nan')):.2g}" for k, v in e["parameters"].items())
            lines.append(f"| {e['title']} (`{e['name']}`) | {ps} | {e['nrmse_before']:.4f} | {e['nrmse_after']:.4f} "
                         f"| {e['shrink']:.0%} ({', '.join(e['shrink_channels'])}) |")
        lines.append("")
    for i, r in enumerate(res.rounds):
        lines += [f"## Round {i + 1}: decision `{r.decision}`", "",
                  f"Current model held-out NRMSE (mean over channels): {r.current_heldout:.4f} "
                  f"({', '.join(f'{k} {v:.4f}' for k, v in r.current_nrmse_heldout.items())})", ""]
        if r.locate.get("worst_windows"):
            lines.append("Largest residuals in windows: " + ", ".join(
                f"{w['window']} ({w['mean_square_weighted_residual']:.3g})" for w in r.locate["worst_windows"]))
            lines.append("")
        if r.separating_experiment:
            lines += [f"Experiment that would separate them: {r.separating_experiment}", ""]
        lines += ["| candidate | signature score | held-out NRMSE | gain | plausible | identifiable | parameters | reasons |",
                  "|---|---|---|---|---|---|---|---|"]
        for c in r.candidates:
            ps = "; ".join(f"{k} = {v:.4g}" for k, v in c.parameters.items())
            lines.append(f"| {c.name} | {c.signature_score:.3f} | {c.heldout:.4f} | {c.gain:+.1%} | {c.plausible} | "
                         f"{c.identifiable} | {ps} | {'; '.join(c.reasons)} |")
        lines.append("")
    lines += _final_model_section(res.final_model_table)
    if res.notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in res.notes] + [""]
    for title, f in figs.items():
        lines += [f"## {title.capitalize()}", "", f"![{title}]({f})", ""]
    lines.append(f"Run time: {res.seconds:.1f} s.")
    md = stage.write("report.md", "\n".join(lines) + "\n")
    stage.write("result.json", json.dumps(res.to_json_dict(), allow_nan=False, indent=1))
    return md

