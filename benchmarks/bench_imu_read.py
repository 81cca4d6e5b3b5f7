"""Benchmark: read a raw 50 kHz IMU CSV of 2 000 000 rows and decimate it to 500 Hz.

Writes ``time_s,ax,ay,az,wx,wy,wz`` (40 s at 50 kHz, noise plus a few sines, ``%.9g``) into a
temporary folder, then prints the median of 3 runs of ``read_imu_csv`` and of
``decimate_imu(..., target_rate_hz=500)``, and the peak RSS (``resource.getrusage``).

Usage: ``python benchmarks/bench_imu_read.py [rows]``
"""

from __future__ import annotations

import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from casrecon.io.decimate import decimate_imu
from casrecon.io.imu import read_imu_csv

RATE_HZ = 50_000.0


def write_raw(path: Path, rows: int, seed: int = 0, block: int = 200_000) -> None:
    """Write the raw file block by block (bounded memory)."""
    rng = np.random.default_rng(seed)
    with open(path, "w", encoding="utf-8") as f:
        f.write("time_s,ax,ay,az,wx,wy,wz\n")
        for start in range(0, rows, block):
            k = np.arange(start, min(rows, start + block))
            t = k / RATE_HZ
            sines = np.column_stack([np.sin(2 * np.pi * fr * t) for fr in (3.0, 80.0, 7000.0)])
            acc = rng.normal(0, 0.5, (k.size, 3)) + sines * [5.0, 2.0, 1.0] + [0, 0, -9.8]
            gyr = rng.normal(0, 0.01, (k.size, 3)) + sines[:, ::-1] * 0.3
            table = np.column_stack([t, acc, gyr])
            f.write("\n".join(",".join(f"{x:.9g}" for x in row) for row in table.tolist()))
            f.write("\n")


def main() -> None:
    rows = int(sys.argv[1]) if len(sys.argv) > 1 else 2_000_000
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "raw_50khz.csv"
        t0 = time.perf_counter()
        write_raw(path, rows)
        print(f"wrote {rows} rows, {path.stat().st_size / 1e6:.1f} MB in "
              f"{time.perf_counter() - t0:.1f} s")
        reads, decs, cpu = [], [], []
        for _ in range(3):
            c0, t0 = time.process_time(), time.perf_counter()
            log = read_imu_csv(path)
            reads.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            t0 = time.perf_counter()
            out = decimate_imu(log, target_rate_hz=500.0)
            decs.append(time.perf_counter() - t0)
            del log
        assert out.n == (rows + 99) // 100
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"read     median {statistics.median(reads):.2f} s (runs "
          f"{', '.join(f'{x:.2f}' for x in reads)}; CPU {statistics.median(cpu):.2f} s)")
    print(f"decimate median {statistics.median(decs):.2f} s (runs "
          f"{', '.join(f'{x:.2f}' for x in decs)}) to {out.n} samples at 500 Hz")
    print(f"peak RSS {peak:.0f} MB")


if __name__ == "__main__":
    main()
