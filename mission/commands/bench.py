"""`mission bench`: the benchmark runner of the source checkout, started as its own program.

bench/ is a development tool and is never installed (its benchmarks need the checkout's data, tests and
tools). With an editable install this verb runs ``python -m bench`` with the checkout first on the child's
``PYTHONPATH`` and forwards every argument (``mission bench --help`` is the runner's help); the package itself
never reaches into bench/. Installed from a wheel, there is no checkout, and the verb says so.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from mission.core.errors import MissionError

CHECKOUT = Path(__file__).resolve().parents[2]  # mission/commands/bench.py → the source checkout


def main(args: argparse.Namespace) -> int:
    if not (CHECKOUT / "bench" / "__main__.py").is_file():
        raise MissionError(
            "`mission bench` runs the benchmarks of a source checkout (bench/ is not installed); "
            "install one editable (`pip install -e .` in a clone) and run it there"
        )
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(CHECKOUT), env.get("PYTHONPATH", "")) if p)
    try:
        return subprocess.call([sys.executable, "-m", "bench", *args.forwarded], env=env)
    except KeyboardInterrupt:  # the runner got the same SIGINT and stops on its own
        return 130
