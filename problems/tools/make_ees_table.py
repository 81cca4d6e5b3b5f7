"""Write the REPRESENTATIVE 52.5 deg sphere-cone aero table (problems/aero/ees-sphere-cone.csv).

The real EES aero database is not public. These smooth shapes have the character of a blunt
sphere-cone at low subsonic speed: axial force falling with angle of attack, normal force growing
like a bluff body's crossflow drag, a statically stable pitching moment about the wind-tunnel MRP,
and negative pitch damping. C_A0 = 0.83 reproduces the EES paper's Table 1 flight times and impact
speeds with the representative UTTR soundings (see tests/acceptance/test_ees_table1.py).

Run: python problems/tools/make_ees_table.py
"""

from pathlib import Path

import numpy as np

CA0 = 0.83


def coefficients(mach: float, alpha_t_deg: np.ndarray):
    s = np.sin(np.radians(alpha_t_deg))
    compressibility = 1 + 0.3 * mach**2
    ca = CA0 * compressibility * (1 - 0.25 * s**2)
    cn = compressibility * (0.12 * s + 0.45 * s**3)
    cm = compressibility * (-0.14 * s - 0.06 * s**3)
    cmq = -0.12 - 0.10 * s**2
    return ca, cn, cm, cmq


def main() -> None:
    alpha = np.arange(0.0, 180.0 + 1e-9, 5.0)
    rows = ["mach,alpha_t_deg,CA,CN,Cm,Cmq"]
    for mach in (0.0, 0.1, 0.2, 0.3, 0.4):
        for a, *c in zip(alpha, *coefficients(mach, alpha)):
            rows.append(f"{mach:.2f},{a:.1f}," + ",".join(f"{v:.6f}" for v in c))
    out = Path(__file__).resolve().parents[1] / "aero" / "ees-sphere-cone.csv"
    out.write_text("\n".join(rows) + "\n")
    print(f"wrote {out} ({len(rows) - 1} points)")


if __name__ == "__main__":
    main()
