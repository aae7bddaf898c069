"""Where a result came from: the code's commit, the command, the libraries and the machine.

Every JSON the benchmarks and ``acnmp experiment --json`` write carries :func:`provenance` under
the key ``provenance``, so a published number can be traced to the code and settings that produced
it (and re-run).
"""
from __future__ import annotations

import os
import platform
import shlex
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

#: Distributions whose versions change results or speed.
LIBRARIES = ("acnmp", "torch", "numpy", "pybullet", "eclipse-zenoh", "rerun-sdk", "msgpack")
ROOT = Path(__file__).resolve().parents[1]
#: Paths whose changes do not make the tree "dirty" (git pathspecs): pages and results.
NOT_CODE = ("*.md", "benchmarks/results", "benchmarks/studies/*/results/*")


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def provenance(argv: list[str] | None = None) -> dict:
    """A JSON-ready record of this run's origin.

    Returns ``{"commit": sha or None, "dirty": bool or None (tracked files other than
    :data:`NOT_CODE` changed), "command":
    str, "started_at": ISO time (UTC), "python": version, "libraries": {name: version},
    "machine": {"platform", "cpu", "cpu_count", "torch_threads", "torch_cpu_capability"}}``
    (the capability is the SIMD level torch's kernels dispatch to, e.g. "AVX2", "AVX512"). ``commit`` is None outside
    a git checkout (an installed wheel).
    """
    import torch

    commit = _git("rev-parse", "HEAD")
    # Pages and results do not change what the code computes: a tree whose only changes are there
    # (e.g. a page being rewritten while a benchmark runs) is not dirty.
    status = _git("status", "--porcelain", "--untracked-files=no", "--", ".", *(f":!{p}" for p in NOT_CODE))
    argv = list(sys.argv if argv is None else argv)
    if argv:
        argv[0] = os.path.relpath(argv[0], ROOT) if os.path.isabs(argv[0]) else argv[0]
    return {
        "commit": commit,
        "dirty": None if status is None else bool(status),
        "command": shlex.join(argv),
        "started_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "python": platform.python_version(),
        "libraries": {name: _version(name) for name in LIBRARIES},
        "machine": {"platform": platform.platform(), "cpu": _cpu_model(), "cpu_count": os.cpu_count(),
                    "torch_threads": torch.get_num_threads(),
                    "torch_cpu_capability": torch.backends.cpu.get_cpu_capability()},
    }
