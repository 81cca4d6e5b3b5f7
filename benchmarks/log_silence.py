"""Longest silent stretch of a ``casrecon`` command's log (not a test; prints its figures).

Runs ``casrecon ARGS...`` with stderr redirected to a pipe (as a log file would be), timestamps
each line (and each ``\\r``-separated redraw) as it arrives, and prints the longest gaps between
consecutive lines with the line that ended each gap, the time to the first line and from the last
line to the end, whether any ``\\r`` reached the pipe, and the longest stretch with only
heartbeat lines (``<stage>: still running (N s)``, casrecon.progress.heartbeat).

Run: python benchmarks/log_silence.py [--top 5] [--save LOG] -- fit problems/ees-drop-1 --out /tmp/x
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path


def timed_lines(cmd: list[str]) -> tuple[list[tuple[float, str]], float, int, bool]:
    """``([(seconds since start, line)], total seconds, exit code, any \\r seen)`` of ``cmd``'s stderr
    (its stdout is read in the same stream, as ``2>&1`` would, unbuffered)."""
    t0 = time.perf_counter()
    env = dict(os.environ, PYTHONUNBUFFERED="1")  # stdout lines when printed, as on a terminal
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)
    lines: list[tuple[float, str]] = []
    carriage = False
    buf = b""
    assert proc.stdout is not None
    while True:
        chunk = proc.stdout.read1(4096)
        if not chunk:
            break
        now = time.perf_counter() - t0
        carriage |= b"\r" in chunk
        buf += chunk.replace(b"\r", b"\n")
        *done, buf = buf.split(b"\n")
        lines += [(now, part.decode(errors="replace")) for part in done if part.strip()]
    if buf.strip():
        lines.append((time.perf_counter() - t0, buf.decode(errors="replace")))
    code = proc.wait()
    return lines, time.perf_counter() - t0, code, carriage


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=5, help="how many of the longest gaps to print")
    ap.add_argument("--save", type=Path, help="also write the timestamped log here")
    ap.add_argument("args", nargs=argparse.REMAINDER, help="casrecon's arguments (after --)")
    args = ap.parse_args()
    argv = args.args[1:] if args.args[:1] == ["--"] else args.args
    lines, total, code, carriage = timed_lines([sys.executable, "-m", "casrecon", *argv])
    stamps = [0.0] + [t for t, _ in lines] + [total]
    texts = [t for _, t in lines] + ["(end of the command)"]
    gaps = sorted(((stamps[i + 1] - stamps[i], stamps[i + 1], texts[i]) for i in range(len(texts))),
                  reverse=True)
    if args.save is not None:
        args.save.write_text("".join(f"{t:8.2f}  {s}\n" for t, s in lines))
    print(f"casrecon {' '.join(argv)}: exit {code}, {total:.1f} s, {len(lines)} lines, "
          f"\\r in the log: {'yes' if carriage else 'no'}")
    print(f"  first line after {stamps[1] if lines else total:.1f} s; "
          f"last line to the end {total - (stamps[-2] if lines else 0.0):.1f} s")
    for gap, at, text in gaps[:args.top]:
        print(f"  silent {gap:6.1f} s, ended at {at:7.1f} s by: {text[:100]}")
    news = [0.0] + [t for t, line in lines if ": still running (" not in line] + [total]
    beats = sum(": still running (" in line for _, line in lines)
    print(f"  heartbeat lines ('still running'): {beats}; longest stretch without another line "
          f"{max(b - a for a, b in zip(news, news[1:])):.1f} s")


if __name__ == "__main__":
    main()
