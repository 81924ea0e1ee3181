"""`python -m bench`: the benchmark runner (bench/command.py)."""

import sys

from bench.command import main

sys.exit(main())
