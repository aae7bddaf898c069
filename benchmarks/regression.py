"""The pinned regression runs: small, exact versions of E1, E2 and E3 that guard the defaults.

``benchmarks/results/regression.json`` holds, for E1 seed 0 (all three methods), E2 seed 0 (both
cases, both methods) and E3 with 20 new environments and 200 test environments (both methods),
the exact roll-out counts and successes. ``tests/unit/test_published_numbers.py`` re-runs them and fails on any
difference, so a change of a default, of the algorithm or of a task cannot silently change the
published numbers: whoever changes them re-runs the full benchmarks and this pin in the same commit.

The runs are bit-identical from one run to the next on one machine, but not from one CPU to
another: the same commit gave E1 seed 0 RL-only 25 roll-outs on an AMD EPYC and 35 on an Intel Xeon
with AVX-512 (E2 seed 0 ProMP + RL 364 and 155; ACNMP's counts were the same on both). Forcing
torch's AVX2 kernels (``ATEN_CPU_CAPABILITY=avx2``) on the Xeon did not bring back the EPYC's
numbers, so identity across machines is not cheap. The pin is therefore kept **per machine**
(:func:`machine_key`: CPU model and torch's SIMD level): on a machine that has a pin every count
must be identical; on one that has none, only what held on every machine measured so far (each
run's success, the failed adaptations) is compared, and ``--write`` adds that machine's pin.

A deliberate change of the pinned runs (a new default) is re-pinned with ``--write --supersede``:
this machine's pin is replaced and every other machine's pin is dropped, since it describes the old
behaviour; the file records which pins were superseded, at which commit. Until a superseded machine
writes its pin again, it is compared as an unpinned one (successes only), against the new pin.

Usage::

    python benchmarks/regression.py           # measure and compare with the pin (exit 1 on a difference)
    python benchmarks/regression.py --write   # measure and write (add or replace) this machine's pin
    python benchmarks/regression.py --write --supersede   # after a deliberate change: drop the others
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
PIN = ROOT / "benchmarks" / "results" / "regression.json"
#: E3's pinned size: new environments, test environments.
E3_ENVS, E3_TEST = 20, 200


def measure_e1() -> dict:
    """E1 seed 0: per method, roll-outs and success."""
    from acnmp_core.experiments.viapoint import run_viapoint

    s = run_viapoint(0, progress=False, assimilation_steps=0).summary
    return {m: {"rollouts": r["rollouts"], "success": r["success"]} for m, r in s["methods"].items()}


def measure_e2() -> dict:
    """E2 seed 0: per method and case, roll-outs and success."""
    from acnmp_core.experiments.push import run_push

    r = run_push([0])
    return {run["method"] + "/" + run["case"]: {"rollouts": run["rollouts"], "success": run["success"]}
            for run in r["runs"]}


def measure_e3() -> dict:
    """E3 with E3_ENVS new and E3_TEST test environments: per method, roll-outs per environment,
    whether each adaptation succeeded, and the final test success rate."""
    from acnmp_core.experiments.wall import run_wall

    r = run_wall(E3_ENVS, 0, n_test=E3_TEST, eval_every=E3_ENVS)
    return {m: {"rollouts_per_env": r["rollouts_per_env"][m], "test_success_rate": s["test_success_rate"],
                "adaptations_failed": s["adaptations_failed"]} for m, s in r["methods"].items()}


def measure() -> dict:
    """All pinned quantities (single-threaded torch, as the benchmarks run)."""
    torch.set_num_threads(1)
    return {"e1_seed0": measure_e1(), "e2_seed0": measure_e2(), "e3_envs20": measure_e3()}


#: Leaves of the pinned runs that held on every machine measured so far (see the module docstring).
STABLE_LEAVES = ("success", "adaptations_failed")


def machine_key(machine: dict) -> str:
    """The key of a machine's pin: ``"<cpu model>, <torch CPU capability>"`` from a provenance's
    ``machine`` record (the CPU model alone for records that predate the capability)."""
    cap = machine.get("torch_cpu_capability")
    return f"{machine['cpu']}, {cap}" if cap else str(machine["cpu"])


def written_pins(pins: dict[str, dict], key: str, pin: dict, *, supersede: bool,
                 superseded: dict[str, dict], commit: str) -> tuple[dict[str, dict], dict[str, dict]]:
    """The pins and the superseded record after writing ``pin`` for machine ``key``.

    Without ``supersede`` the other machines' pins are kept. With it they are dropped and each
    dropped key is recorded in the returned superseded record as ``{"by_commit": commit,
    "pinned_at": <its pin's commit>}`` (earlier records are kept unless that machine is pinned again).
    """
    superseded = {k: v for k, v in superseded.items() if k != key}
    if supersede:
        for k, old in pins.items():
            if k != key:
                superseded[k] = {"by_commit": commit, "pinned_at": old["provenance"]["commit"]}
        pins = {}
    return {**pins, key: pin}, superseded


def load_pins(path: Path = PIN) -> dict[str, dict]:
    """The pins in ``path``: machine key -> ``{"provenance": ..., "runs": {...}}``."""
    return json.loads(Path(path).read_text())["machines"]


def pin_for(pins: dict[str, dict], key: str) -> dict | None:
    """The pinned runs for machine ``key``, or for its CPU model alone (a pin written before the
    capability was recorded), or None."""
    for k in (key, key.split(", ")[0]):
        if k in pins:
            return pins[k]["runs"]
    return None


def differences(pinned: dict, measured: dict, path: str = "", leaves: tuple[str, ...] | None = None) -> list[str]:
    """'path: pinned -> measured' for every leaf that differs (only leaves named in ``leaves``
    when given)."""
    if isinstance(pinned, dict) and isinstance(measured, dict):
        out = []
        for k in sorted(set(pinned) | set(measured)):
            sub_p, sub_m = pinned.get(k), measured.get(k)
            if leaves is not None and not isinstance(sub_p, dict) and not isinstance(sub_m, dict) and k not in leaves:
                continue
            out += differences(sub_p, sub_m, f"{path}/{k}" if path else k, leaves)
        return out
    return [] if pinned == measured else [f"{path}: {pinned!r} -> {measured!r}"]


def compare(pins: dict[str, dict], measured: dict, key: str) -> tuple[bool, list[str]]:
    """Compare ``measured`` with the pins. Returns (exact, differences): ``exact`` is True when
    machine ``key`` has a pin and every leaf was compared; otherwise only :data:`STABLE_LEAVES`
    were compared, against every machine's pin."""
    own = pin_for(pins, key)
    if own is not None:
        return True, differences(own, measured)
    diff = []
    for k, pin in sorted(pins.items()):
        diff += [f"[{k}] {d}" for d in differences(pin["runs"], measured, leaves=STABLE_LEAVES)]
    return False, diff


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="write (add or replace) this machine's pin")
    ap.add_argument("--supersede", action="store_true",
                    help="with --write: drop every other machine's pin (after a deliberate change of the runs)")
    args = ap.parse_args(argv)
    if args.supersede and not args.write:
        ap.error("--supersede: only with --write")
    from clients.provenance import provenance

    torch.set_num_threads(1)  # before provenance(), so the record names the threads measure() runs with
    meta = provenance()
    key = machine_key(meta["machine"])
    measured = measure()
    stored = json.loads(PIN.read_text()) if PIN.exists() else {}
    pins = stored.get("machines", {})
    if args.write:
        pins, superseded = written_pins(pins, key, {"provenance": meta, "runs": measured}, supersede=args.supersede,
                                        superseded=stored.get("superseded", {}), commit=meta["commit"])
        out = {"provenance": meta, "machines": pins, **({"superseded": superseded} if superseded else {})}
        PIN.write_text(json.dumps(out, indent=2) + "\n")
        dropped = f"; superseded {sorted(superseded)}" if args.supersede and superseded else ""
        print(f"wrote the pin of {key!r} to {PIN}{dropped}")
        return 0
    exact, diff = compare(pins, measured, key)
    for line in diff:
        print(line)
    scope = "every count" if exact else f"successes only (no pin for {key!r}; --write adds one)"
    print(f"regression ({scope}): " + ("identical" if not diff else f"{len(diff)} difference(s)"))
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
