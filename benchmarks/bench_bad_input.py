"""Wall time of the command line on every bad-input case of the reliability tests.

    PYTHONPATH=. python benchmarks/bench_bad_input.py

Prints one line per case: exit code, seconds, and the error line. Each case must end in one line
with exit code 2 before any work (the target on an idle machine: under 2 s).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_reliability import _bad_inputs, cli  # noqa: E402


def main():
    with tempfile.TemporaryDirectory() as tmp:
        worst = 0.0
        for name, args, _ in _bad_inputs(Path(tmp)):
            res, seconds = cli(*args)
            worst = max(worst, seconds)
            line = res.stderr.strip().splitlines()
            print(f"{name:30s} exit {res.returncode}  {seconds:5.2f} s  "
                  f"{line[0][:90] if line else ''}")
        print(f"slowest: {worst:.2f} s")


if __name__ == "__main__":
    main()
