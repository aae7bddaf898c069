"""Run through the spawner by tests/e2e/test_spawner.py: prints ``NAME=value`` for each environment
variable named on its command line (a forked child's /proc/PID/environ is its spawner's, so the test
asks the child itself)."""
import os
import sys

for name in sys.argv[1:]:
    print(f"{name}={os.environ.get(name)}")
