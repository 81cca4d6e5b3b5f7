"""A joint fit that fails ends the command at once: the single-drop fits of the sigma comparison,
which run on two processes beside the joint fit, are stopped, not waited for."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = textwrap.dedent("""
    import time
    import casrecon.estimation.sixdof.joint as joint
    from casrecon.cli import main
    from casrecon.cli_guard import exit_process
    from casrecon.estimation.sixdof.fit import FitError

    def fails(*args, **kwargs):
        time.sleep(1.0)  # the single-drop fits have started by now
        raise FitError("made to fail")

    if __name__ == "__main__":  # the spawned workers import this file too
        joint.fit_joint = fails
        exit_process(main(["joint", {joint_toml!r}, "--out", {out!r}, "--no-figures", "--quiet"]))
""")


def test_a_failed_joint_fit_stops_the_single_drop_fits(tmp_path):
    script = tmp_path / "fail_joint.py"
    out = tmp_path / "out"
    script.write_text(SCRIPT.format(joint_toml=str(ROOT / "problems" / "ees-joint.toml"), out=str(out)))
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=ROOT)
    seconds = time.perf_counter() - t0
    assert proc.returncode == 3, proc.stderr
    assert "joint fit ees-joint failed: made to fail" in proc.stderr
    assert not out.exists()
    # the four single-drop fits alone take 5 s or more on two workers; stopped, the command ends
    # about 1 s after its (made) failure
    assert seconds < 5.0, f"{seconds:.1f} s: the single-drop fits were waited for"
