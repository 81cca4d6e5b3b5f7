"""Write the REPRESENTATIVE UTTR soundings used by the synthetic drop problems.

No public Dugway or Salt Lake City sounding for October 2023 was available, so each drop gets a
plausible October morning profile over the Utah Test and Training Range: ground at 1310 m MSL,
a shallow surface inversion, 6.5 K/km above it, hydrostatic pressure, and light winds (2 to 8 m/s)
that veer with height. Each profile is seeded so the files are reproducible.

Run: python problems/tools/make_uttr_soundings.py
"""

from pathlib import Path

import numpy as np

G0, R_AIR = 9.80665, 287.05287
GROUND_MSL = 1310.0
DROPS = {  # folder: (surface temperature K, surface pressure Pa, seed)
    "ees-drop-1": (284.0, 86650.0, 11),
    "ees-drop-2": (286.5, 86500.0, 12),
    "ees-drop-3": (282.0, 86900.0, 13),
    "ees-drop-4": (283.5, 86800.0, 14),
    "davinci-ztu": (285.0, 86600.0, 15),
}


def profile(t0: float, p0: float, seed: int, top_msl: float = 8000.0):
    rng = np.random.default_rng(seed)
    h = np.arange(GROUND_MSL, top_msl + 1, 50.0)
    z = h - GROUND_MSL
    temp = t0 + np.where(z < 300, 0.004 * z, 1.2 - 0.0065 * (z - 300))
    logp = np.log(p0) - np.concatenate([[0], np.cumsum(G0 / (R_AIR * 0.5 * (temp[1:] + temp[:-1])) * np.diff(h))])
    k = rng.uniform(0.3, 1.0, 3)
    phase = rng.uniform(0, 2 * np.pi, 3)
    speed = 2.0 + 2.5 * z / 1000 + 0.8 * np.sin(2 * np.pi * z / (800 * k[0]) + phase[0])
    direction = (rng.uniform(180, 300) + 25 * z / 1000 + 10 * np.sin(2 * np.pi * z / (1200 * k[1]) + phase[1])) % 360
    return h, np.exp(logp), temp, direction, np.clip(speed, 0.2, None)


def main() -> None:
    root = Path(__file__).resolve().parents[1]
    for folder, (t0, p0, seed) in DROPS.items():
        rows = ["altitude_msl_m,pressure_pa,temperature_k,wind_dir_deg,wind_speed_mps"]
        for values in zip(*profile(t0, p0, seed)):
            rows.append("{:.1f},{:.2f},{:.2f},{:.1f},{:.2f}".format(*values))
        out = root / folder / "sounding.csv"
        out.parent.mkdir(exist_ok=True)
        out.write_text("\n".join(rows) + "\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
