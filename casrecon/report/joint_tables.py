"""Markdown tables of a joint fit: the shared factors (EES Table 5 style), a per-drop summary, the
model-adequacy verdict, and the joint against the single-drop sigmas."""

from __future__ import annotations

import numpy as np


def _table5(result) -> list[str]:
    lines = ["### Shared aero dispersions (EES Table 5 style)", "",
             "Normalised factors (database 3-sigma = 1), estimated from all drops in one NLP.", "",
             "| factor | estimate | 3-sigma |", "|---|---|---|"]
    for n in result.shared:
        i = result.names.index(n)
        lines.append(f"| {n} | {result.values[i]:.4f} | {3 * result.sigma[i]:.4f} |")
    return lines


def _per_drop(result, reconciled: dict[str, dict]) -> list[str]:
    lines = ["### Per-drop summary", "",
             "| drop | window, s after release | chi2 / n | wind bias N, E (m/s) | density factor | "
             "end speed, m/s | reconciled dt, s | reconciled dV, m/s |", "|---|---|---|---|---|---|---|---|"]
    for d in result.drops:
        name = d.scenario.config.name
        w = d.data.window
        chi2, n = sum(d.chi2.values()), sum(d.n_measurements.values())
        wn, we = d.parameter("wind_bias_n")[0], d.parameter("wind_bias_e")[0]
        rho = d.parameter("density_factor")[0]
        rec = reconciled.get(name, {})
        lines.append(f"| {name} | {w[0] - d.data.release_imu_s:.2f} to {w[1] - d.data.release_imu_s:.2f} | "
                     f"{chi2:.0f} / {n} | {wn:+.3f}, {we:+.3f} | {rho:+.5f} | "
                     f"{np.linalg.norm(d.states[-1, 3:6]):.2f} | "
                     f"{rec.get('flight_time_difference_s', float('nan')):+.3f} | "
                     f"{rec.get('impact_speed_difference_mps', float('nan')):+.3f} |")
    return lines


def _sigma_comparison(result, single: dict[str, dict[str, float]]) -> list[str]:
    if not single:
        return ["### Joint vs single-drop sigma", "", "Single-drop fits were not run (--no-single)."]
    drops = list(single)
    lines = ["### Joint vs single-drop sigma", "",
             "1-sigma of each shared factor in the joint fit and in each drop's own fit; the last column is "
             "the joint sigma over the smallest single-drop sigma.", "",
             "| factor | joint | " + " | ".join(drops) + " | joint / best single |",
             "|---" * (len(drops) + 3) + "|"]
    for n in result.shared:
        js = result.sigma[result.names.index(n)]
        singles = [single[d].get(n, float("nan")) for d in drops]
        best = np.nanmin(singles)
        lines.append(f"| {n} | {js:.4g} | " + " | ".join(f"{s:.4g}" for s in singles) + f" | {js / best:.3f} |")
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
