"""Study: can the pinned learning runs give the same floats on every x86 CPU, and at what cost?

For each numerics mode (:data:`MODES`: torch/MKL/numpy defaults, or MKL's conditional numerical
reproducibility set to COMPATIBLE), computes the canary of ``benchmarks/numerics.py`` (a hash of
every float of short E1 and E2 runs) natively and, with ``--emulate``, under ``qemu-x86_64`` for
other CPU models (an Intel Haswell reports the same torch SIMD level, AVX2, as this AMD EPYC).
Then times the pinned E3 (20 environments, 200 test ones) in each mode, alternately, ``--repeats``
times, and reports the ratio to the default. Each run is a fresh process (MKL reads its settings
at load time).

    python benchmarks/studies/numerics/study_numerics.py --emulate Haswell-v4,EPYC-Milan --out benchmarks/studies/numerics/results/study_numerics.json
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

#: Numerics modes: name -> environment added to the process.
MODES = {"default": {}, "mkl_cbwr_compatible": {"MKL_CBWR": "COMPATIBLE"}}

CANARY = "import sys, torch; sys.path.insert(0, '.'); torch.set_num_threads(1)\n" \
         "from benchmarks.numerics import canary; print(canary())"
E3 = "import sys, time, torch; sys.path.insert(0, '.'); torch.set_num_threads(1)\n" \
     "from acnmp_core.experiments.wall import run_wall\n" \
     "t = time.perf_counter(); run_wall(20, 0, n_test=200, eval_every=20); print(time.perf_counter() - t)"


def run(code: str, env: dict[str, str], cpu: str | None = None) -> str:
    """Run ``code`` in a fresh Python (under qemu with CPU model ``cpu`` when given); its last line."""
    cmd = [sys.executable, "-c", code]
    if cpu:
        cmd = ["qemu-x86_64", "-cpu", cpu, *cmd]
    out = subprocess.run(cmd, cwd=ROOT, env={**os.environ, **env}, capture_output=True, text=True, check=True)
    return out.stdout.strip().splitlines()[-1]


def main(argv: list[str] | None = None) -> int:
    from clients.experiments.common import add_run_arguments

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--emulate", default="", help="comma-separated qemu CPU models to compute the canary on too")
    ap.add_argument("--emulate-modes", default="default",
                    help="comma-separated modes whose canary is also computed under emulation (each takes minutes)")
    ap.add_argument("--emulated-earlier", nargs="*", default=[], metavar="NAME=FILE",
                    help="emulated canaries measured earlier (each takes 13-17 min): NAME=FILE with the JSON "
                         "{'env': MKL_CBWR or null, 'fp': fingerprint, 's': seconds} a run under qemu printed")
    ap.add_argument("--repeats", type=int, default=2, help="timed E3 runs per mode (alternating)")
    add_run_arguments(ap, out=str((Path(__file__).resolve().parent / "results") / "study_numerics.json"))
    args = ap.parse_args(argv)
    cpus = [c for c in args.emulate.split(",") if c]
    if cpus and not shutil.which("qemu-x86_64"):
        ap.error("--emulate: qemu-x86_64 not found (apt install qemu-user)")
    from benchmarks._results import save_result
    from clients.provenance import provenance

    result = {"provenance": provenance(), "modes": MODES, "canary": {}, "e3_seconds": {m: [] for m in MODES}}
    for mode, env in MODES.items():
        result["canary"][mode] = {"native": run(CANARY, env)}
        for cpu in cpus if mode in args.emulate_modes.split(",") else []:
            t0 = time.perf_counter()
            result["canary"][mode][f"qemu {cpu}"] = run(CANARY, env, cpu)
            print(f"{mode} on {cpu}: {time.perf_counter() - t0:.0f} s", flush=True)
    for item in args.emulated_earlier:
        name, _, path = item.partition("=")
        rec = json.loads(Path(path).read_text().strip().splitlines()[-1])
        mode = "mkl_cbwr_compatible" if rec["env"] == "COMPATIBLE" else "default"
        result["canary"][mode][f"qemu {name} (earlier run)"] = rec["fp"]["canary"]
        result.setdefault("emulated_fingerprints", {})[f"{mode} qemu {name}"] = {**rec["fp"], "seconds": rec["s"]}
    for _ in range(args.repeats):
        for mode, env in MODES.items():
            result["e3_seconds"][mode].append(float(run(E3, env)))
    base = min(result["e3_seconds"]["default"])
    result["e3_time_ratio_to_default"] = {m: min(v) / base for m, v in result["e3_seconds"].items()}
    result["identical_across_cpus"] = {m: len(set(c.values())) == 1 for m, c in result["canary"].items() if len(c) > 1}
    result["headline"] = {"identical_across_cpus": result["identical_across_cpus"],
                          "e3_time_ratio_to_default": result["e3_time_ratio_to_default"]}
    return save_result(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
