"""Markdown tables of a joint fit: the shared factors (EES Table 5 style), a per-drop summary, the
model-adequacy verdict, and the joint against the single-drop sigmas."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _table5(result) -> list[str]:
    lines = ["### Shared aero dispersions (EES Table 5 style)", "",
             "Normalised factors (database 3-sigma = 1), estimated from all drops in one NLP.", "",
             "| factor | estimate | 3-sigma |", "|---|---|---|"]
    for n in result.shared:
        i = result.names.index(n)
        lines.append(f"| {n} | {result.values[i]:.4f} | {3 * result.sigma[i]:.4f} |")
    return lines


@dataclass(frozen=True)
class DropRow:
    """One drop's line of the per-drop summary of a joint fit (its part of the joint solution)."""

    name: str
    window_s: tuple[float, float]  # s after release
    chi2: float  # -, every group of the drop
    n: int  # measurements
    wind_bias_mps: tuple[float, float]  # north, east, m/s
    density_factor: float  # -
    end_speed_mps: float  # m/s, at the last node
    reconciled_dt_s: float  # s, simulated minus reconstructed flight time
    reconciled_dv_mps: float  # m/s, simulated minus reconstructed impact speed


def per_drop_rows(result, reconciled: dict[str, dict]) -> list[DropRow]:
    """Each drop's :class:`DropRow` (``reconciled``: drop -> reconciled-simulation summary, s, m/s)."""
    rows = []
    for d in result.drops:
        name = d.scenario.config.name
        w = d.data.window
        rec = reconciled.get(name, {})
        rows.append(DropRow(name, (w[0] - d.data.release_imu_s, w[1] - d.data.release_imu_s), sum(d.chi2.values()),
                            sum(d.n_measurements.values()),
                            (d.parameter("wind_bias_n")[0], d.parameter("wind_bias_e")[0]),
                            d.parameter("density_factor")[0], float(np.linalg.norm(d.states[-1, 3:6])),
                            rec.get("flight_time_difference_s", float("nan")),
                            rec.get("impact_speed_difference_mps", float("nan"))))
    return rows


def _per_drop(result, reconciled: dict[str, dict]) -> list[str]:
    lines = ["### Per-drop summary", "",
             "| drop | window, s after release | chi2 / n | wind bias N, E (m/s) | density factor | "
             "end speed, m/s | reconciled dt, s | reconciled dV, m/s |", "|---|---|---|---|---|---|---|---|"]
    for r in per_drop_rows(result, reconciled):
        lines.append(f"| {r.name} | {r.window_s[0]:.2f} to {r.window_s[1]:.2f} | {r.chi2:.0f} / {r.n} | "
                     f"{r.wind_bias_mps[0]:+.3f}, {r.wind_bias_mps[1]:+.3f} | {r.density_factor:+.5f} | "
                     f"{r.end_speed_mps:.2f} | {r.reconciled_dt_s:+.3f} | {r.reconciled_dv_mps:+.3f} |")
    return lines


def sigma_rows(result, single: dict[str, dict[str, float]]) -> list[tuple[str, float, list[float], float]]:
    """Per shared factor: its name, joint 1-sigma, each drop's own 1-sigma (in the order of
    ``single``; NaN where missing) and the joint over the smallest single-drop sigma (-)."""
    rows = []
    for n in result.shared:
        js = result.sigma[result.names.index(n)]
        singles = [single[d].get(n, float("nan")) for d in single]
        rows.append((n, js, singles, js / np.nanmin(singles)))
    return rows


def _sigma_comparison(result, single: dict[str, dict[str, float]]) -> list[str]:
    if not single:
        return ["### Joint vs single-drop sigma", "", "Single-drop fits were not run (--no-single)."]
    drops = list(single)
    lines = ["### Joint vs single-drop sigma", "",
             "1-sigma of each shared factor in the joint fit and in each drop's own fit; the last column is "
             "the joint sigma over the smallest single-drop sigma.", "",
             "| factor | joint | " + " | ".join(drops) + " | joint / best single |",
             "|---" * (len(drops) + 3) + "|"]
    for n, js, singles, ratio in sigma_rows(result, single):
        lines.append(f"| {n} | {js:.4g} | " + " | ".join(f"{s:.4g}" for s in singles) + f" | {ratio:.3f} |")
    return lines


def _adequacy(adequacy) -> list[str]:
    if adequacy is None:
        return []
    lines = ["### Model adequacy", "", f"**{adequacy.line}**", "", "| drop | verdict |", "|---|---|"]
    lines += [f"| {n} | {a.line} |" for n, a in adequacy.drops]
    return lines + [""]


def joint_tables(result, single: dict, reconciled: dict, adequacy=None) -> str:
    """``tables.md`` of a joint fit: ``single`` maps drop -> parameter -> single-drop 1-sigma (may be
    empty), ``reconciled`` maps drop -> reconciled-simulation summary (s, m/s), ``adequacy`` is the
    :class:`~casrecon.analysis.fit_adequacy.JointAdequacy` verdict (its section left out when None)."""
    head = [f"# {result.config.name}: joint aero fit of {len(result.drops)} drops", "",
            f"{result.status} in {result.iterations} iterations; reduced chi-square {result.reduced_chi2:.4f}.", ""]
    return "\n".join(head + _table5(result) + [""] + _per_drop(result, reconciled) + [""] + _adequacy(adequacy)
                     + _sigma_comparison(result, single)) + "\n"
