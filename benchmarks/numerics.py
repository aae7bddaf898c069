"""Which floats a machine computes: the fingerprint that decides whether a pin's exact counts apply.

Two machines that report the same CPU name and the same torch SIMD level can still compute
different floats (``benchmarks/studies/numerics/README.md``): the first difference between an AMD EPYC and an
Intel Haswell running E1 seed 0 is the first ``addmm`` of the CNMP encoder in the first training
step, where MKL picks a vendor-specific SGEMM kernel. A chaotic learning run then drifts to other
roll-out counts. So a pin's exact counts are compared only on a machine whose :func:`fingerprint`
equals the pin's, in every field:

* ``cpu``: vendor, family, model, stepping, model name and a hash of the CPU flags
  (``/proc/cpuinfo``), since kernels are chosen from these;
* ``software``: the versions of torch, MKL (as torch was built with it) and numpy, torch's SIMD
  level, numpy's SIMD extensions, torch's thread count, and every environment variable that
  changes which kernels run (:data:`NUMERICS_ENV`);
* ``canary``: a hash of every float of short versions of the pinned runs (E1 and E2 with a few
  training steps and a small budget: CNMP training and adaptation in torch, ProMP + RL in numpy,
  the pushing physics), which exercises the same kernels. (A short E3 takes minutes, too long.) It catches what the
  fields above cannot name (a microcode, a kernel picked from the cache size).
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import re
from typing import Any

import numpy as np

#: Environment variables that change which BLAS / SIMD kernels run, hence the floats.
#: (Thread counts are not among them: ``torch_threads`` records the count the runs used, whatever
#: OMP_NUM_THREADS said; scripts/test.sh sets it, ``benchmarks/regression.py`` does not need to.)
NUMERICS_ENV = ("MKL_CBWR", "MKL_ENABLE_INSTRUCTIONS", "ATEN_CPU_CAPABILITY", "OPENBLAS_CORETYPE",
                "NPY_DISABLE_CPU_FEATURES", "DNNL_MAX_CPU_ISA")
#: Fields of ``/proc/cpuinfo`` that identify a CPU's microarchitecture.
CPU_FIELDS = {"vendor_id": "vendor", "cpu family": "family", "model": "model", "stepping": "stepping",
              "model name": "name"}


def cpu_identity(cpuinfo: str | None = None) -> dict[str, str]:
    """The first CPU's identity from ``/proc/cpuinfo`` text (read when not given).

    Returns ``{"vendor", "family", "model", "stepping", "name", "flags_sha"}`` (strings; the flags
    as the first 16 hex digits of the SHA-256 of the sorted flag list); on a system without
    ``/proc/cpuinfo``, ``{"name": platform.processor()}``.
    """
    if cpuinfo is None:
        try:
            with open("/proc/cpuinfo") as f:
                cpuinfo = f.read()
        except OSError:
            return {"name": platform.processor() or "unknown"}
    first = cpuinfo.split("\n\n", 1)[0]
    out: dict[str, str] = {}
    for line in first.splitlines():
        key, _, value = line.partition(":")
        key, value = key.strip(), value.strip()
        if key in CPU_FIELDS:
            out[CPU_FIELDS[key]] = value
        elif key == "flags":
            out["flags_sha"] = hashlib.sha256(" ".join(sorted(value.split())).encode()).hexdigest()[:16]
    return out


def software_identity() -> dict[str, Any]:
    """The libraries, SIMD levels, threads and environment that decide which kernels run."""
    import torch

    mkl = re.search(r"Math Kernel Library Version ([^\s]+)", torch.__config__.show())
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
        npy_simd = sorted(k for k, v in features.items() if v)
    except ImportError:  # numpy < 2
        npy_simd = []
    return {
        "torch": torch.__version__, "torch_cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "mkl": mkl.group(1) if mkl else None, "numpy": np.__version__,
        "numpy_simd_sha": hashlib.sha256(" ".join(npy_simd).encode()).hexdigest()[:16],
        "torch_threads": torch.get_num_threads(),
        "env": {k: os.environ[k] for k in NUMERICS_ENV if k in os.environ},
    }


def _exact(obj: Any) -> Any:
    """``obj`` with every float as its exact hex form and timing keys dropped (they differ every run)."""
    if isinstance(obj, dict):
        return {str(k): _exact(v) for k, v in obj.items() if "time" not in str(k)}
    if isinstance(obj, (list, tuple)):
        return [_exact(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return hashlib.sha256(np.ascontiguousarray(obj, dtype=np.float64).tobytes()).hexdigest()
    if isinstance(obj, (float, np.floating)):
        return float(obj).hex()
    if isinstance(obj, (np.integer, np.bool_)):
        return obj.item()
    return obj


def canary_runs() -> dict[str, Any]:
    """Short versions of the pinned runs (seed 0): E1 (60 training steps, budget 10) and E2
    extrapolation (60 steps, budgets 10 and 20). Returns their JSON-ready results with floats in
    exact hex form (about 8 s of work)."""
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.baselines.promp_rl import PrompRLConfig
    from acnmp_core.experiments.push import run_push
    from acnmp_core.experiments.viapoint import run_viapoint

    e1 = run_viapoint(0, train_steps=60, budget=10, assimilation_steps=0, progress=False)
    e2 = run_push([0], train_steps=60, cases=("extrapolation",), adapt_config=AdaptConfig.paper(max_rollouts=10),
                  promp_config=PrompRLConfig(method="reps", n_samples=10, max_rollouts=20))
    return _exact({"e1": {"summary": e1.summary, "trajectories": e1.trajectories},
                   "e2": e2["runs"]})


def canary() -> str:
    """SHA-256 (first 16 hex digits) of :func:`canary_runs`: equal on two machines that compute the
    same floats in the kernels the pinned runs use."""
    return hashlib.sha256(json.dumps(canary_runs(), sort_keys=True).encode()).hexdigest()[:16]


def fingerprint(with_canary: bool = True) -> dict[str, Any]:
    """``{"cpu": cpu_identity(), "software": software_identity(), "canary": canary() or None}``."""
    return {"cpu": cpu_identity(), "software": software_identity(),
            "canary": canary() if with_canary else None}


def fingerprint_differences(pinned: dict | None, here: dict) -> list[str]:
    """Why ``here`` is not provably the machine of ``pinned``: one ``"field: pinned -> here"`` per
    differing field (``["no fingerprint (written before fingerprints)"]`` for a pin without one);
    empty when every field is equal."""
    if not pinned:
        return ["no fingerprint (written before fingerprints)"]
    out = []
    for part in ("cpu", "software"):
        a, b = pinned.get(part, {}), here.get(part, {})
        out += [f"{part}.{k}: {a.get(k)!r} -> {b.get(k)!r}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    if pinned.get("canary") != here.get("canary"):
        out.append(f"canary: {pinned.get('canary')} -> {here.get('canary')}")
    return out
