"""The pinned regression runs: small, exact versions of E1, E2 and E3 that guard the defaults.

``benchmarks/results/regression.json`` holds, for E1 seed 0 (all three methods), E2 seed 0 (both
cases, both methods) and E3 with 20 new environments and 200 test environments (both methods),
the roll-out counts and successes, with the :func:`numerics.fingerprint` of the machine that wrote
them. A change of a default, of the algorithm or of a task must not silently change the published
numbers: whoever changes them re-runs the full benchmarks and this pin in the same commit.

The runs are bit-identical from one run to the next on one machine, but not from one machine to
another, even two that report the same CPU name and torch SIMD level (``benchmarks/studies/numerics/README.md``).
So what is compared depends on the machine:

* on the machine that wrote a pin (its fingerprint equal in every field, the canary included),
  **every count** must be identical;
* elsewhere, what holds on every machine: each run's success, the failed adaptations, and each
  roll-out count inside its **band**: the range over the published seeds (``e1_viapoint.json``,
  ``e2_push.json``) widened by :data:`BAND_FACTOR`, since another machine's seed 0 is in effect
  another seed. A one-line note says that exact counts were not compared, and why.

The test suite re-runs E1 (:data:`QUICK`, about 20 s); the whole set (about 4 minutes) runs here.

A deliberate change of the pinned runs (a new default) is re-pinned with ``--write --supersede``:
this machine's pin is replaced and every other machine's pin is dropped, since it describes the old
behaviour; the file records which pins were superseded, at which commit.

Usage::

    python benchmarks/regression.py           # measure and compare with the pin (exit 1 on a difference)
    python benchmarks/regression.py --only e1_seed0   # the suite's quick check
    python benchmarks/regression.py --write   # measure and write (add or replace) this machine's pin
    python benchmarks/regression.py --write --supersede   # after a deliberate change: drop the others
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from dataclasses import dataclass
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


#: The pinned runs by name, each a function measuring it.
RUNS = {"e1_seed0": measure_e1, "e2_seed0": measure_e2, "e3_envs20": measure_e3}
#: What the test suite re-runs (the others take minutes).
QUICK = ("e1_seed0",)
#: A count measured on a machine without a pin must lie in [min / BAND_FACTOR, max * BAND_FACTOR]
#: over the published seeds. The widest cross-machine difference measured at seed 0 is 1.65x (E2
#: ProMP + RL extrapolation: 221 roll-outs on one AMD EPYC, 364 on another).
BAND_FACTOR = 2.0
#: Leaves of the pinned runs that held on every machine measured so far.
STABLE_LEAVES = ("success", "adaptations_failed")


def measure(only: tuple[str, ...] | None = None) -> dict:
    """The pinned quantities of the runs named in ``only`` (default: all of :data:`RUNS`), with
    single-threaded torch as the benchmarks run."""
    torch.set_num_threads(1)
    names = tuple(RUNS) if only is None else only
    unknown = [n for n in names if n not in RUNS]
    if unknown:
        raise ValueError(f"unknown pinned run(s) {unknown}; expected some of {list(RUNS)}")
    return {name: RUNS[name]() for name in names}


def machine_key(machine: dict) -> str:
    """A readable name for a machine: ``"<cpu model>, <torch CPU capability>"`` from a provenance's
    ``machine`` record (the CPU model alone for records that predate the capability). Not enough to
    tell two machines' floats apart: :func:`numerics.fingerprint` is."""
    cap = machine.get("torch_cpu_capability")
    return f"{machine['cpu']}, {cap}" if cap else str(machine["cpu"])


def pin_key(machine: dict, fingerprint: dict) -> str:
    """The key of a pin in the file: the machine's name and a short hash of its fingerprint, so
    two machines with the same name keep two pins."""
    fp = hashlib.sha256(json.dumps(fingerprint, sort_keys=True).encode()).hexdigest()[:8]
    return f"{machine_key(machine)} #{fp}"


def published_bands(results: Path = ROOT / "benchmarks" / "results") -> dict:
    """The roll-out bands of the pinned runs from the published multi-seed results:
    ``{"e1_seed0": {method: {"rollouts": [lo, hi]}}, "e2_seed0": {"method/case": {...}}}`` with
    ``lo = min / BAND_FACTOR`` and ``hi = max * BAND_FACTOR`` over the seeds."""
    def band(counts: list[int]) -> list[float]:
        return [min(counts) / BAND_FACTOR, max(counts) * BAND_FACTOR]

    e1 = json.loads((results / "e1_viapoint.json").read_text())["runs"]
    e2 = json.loads((results / "e2_push.json").read_text())["runs"]
    out: dict[str, dict] = {"e1_seed0": {}, "e2_seed0": {}}
    for method in e1[0]["methods"]:
        out["e1_seed0"][method] = {"rollouts": band([r["methods"][method]["rollouts"] for r in e1])}
    for name in sorted({r["method"] + "/" + r["case"] for r in e2}):
        out["e2_seed0"][name] = {"rollouts": band([r["rollouts"] for r in e2 if r["method"] + "/" + r["case"] == name])}
    return out


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
    """The pins in ``path``: key -> ``{"provenance": ..., "fingerprint": ... (absent in pins written
    before fingerprints), "runs": {...}}``."""
    return json.loads(Path(path).read_text())["machines"]


def differences(pinned: dict, measured: dict, path: str = "", leaves: tuple[str, ...] | None = None) -> list[str]:
    """'path: pinned -> measured' for every leaf that differs (only leaves named in ``leaves``
    when given); subtrees missing from ``measured`` (runs not re-run) are skipped."""
    if isinstance(pinned, dict) and isinstance(measured, dict):
        out = []
        for k in sorted(set(pinned) | set(measured)):
            sub_p, sub_m = pinned.get(k), measured.get(k)
            if isinstance(sub_p, dict) and sub_m is None:
                continue
            if leaves is not None and not isinstance(sub_p, dict) and not isinstance(sub_m, dict) and k not in leaves:
                continue
            out += differences(sub_p, sub_m, f"{path}/{k}" if path else k, leaves)
        return out
    return [] if pinned == measured else [f"{path}: {pinned!r} -> {measured!r}"]


def outside_bands(bands: dict, measured: dict, path: str = "") -> list[str]:
    """'path: value outside [lo, hi]' for every measured count that has a band and lies outside it."""
    out = []
    for k, band in bands.items():
        sub, where = measured.get(k) if isinstance(measured, dict) else None, f"{path}/{k}" if path else k
        if sub is None:
            continue
        if isinstance(band, dict):
            out += outside_bands(band, sub, where)
        elif not band[0] <= sub <= band[1]:
            out.append(f"{where}: {sub} outside the band [{band[0]:g}, {band[1]:g}]")
    return out


@dataclass(frozen=True)
class Comparison:
    """The result of :func:`compare`. ``exact``: every count was compared with this machine's own
    pin; ``differences``: one line per failed check (empty: the check passed); ``note``: one line
    saying what was compared and, when not exact, why."""

    exact: bool
    differences: list[str]
    note: str


def compare(pins: dict[str, dict], measured: dict, here: dict, bands: dict | None = None) -> Comparison:
    """Compare ``measured`` (a subset of :data:`RUNS` allowed) with the pins, for a machine whose
    :func:`numerics.fingerprint` is ``here``. Every count is compared with the pin whose fingerprint
    equals ``here``; without one, the stable leaves against every pin and the counts against
    ``bands`` (default :func:`published_bands`)."""
    from benchmarks.numerics import fingerprint_differences

    why: dict[str, list[str]] = {}
    for key, pin in sorted(pins.items()):
        why[key] = fingerprint_differences(pin.get("fingerprint"), here)
        if not why[key]:
            return Comparison(True, differences(pin["runs"], measured),
                              f"every count compared with the pin {key!r} (same fingerprint)")
    diff = []
    for key, pin in sorted(pins.items()):
        diff += [f"[{key}] {d}" for d in differences(pin["runs"], measured, leaves=STABLE_LEAVES)]
    diff += outside_bands(published_bands() if bands is None else bands, measured)
    closest = min(why, key=lambda k: len(why[k])) if why else None
    if closest is None:
        reason = "no pin"
    elif not pins[closest].get("fingerprint"):
        reason = f"closest pin {closest!r} has no fingerprint (written before fingerprints)"
    else:
        reason = f"closest pin {closest!r} differs in {', '.join(why[closest])}"
    return Comparison(False, diff, "exact counts not compared (no pin from this machine: "
                      f"{reason}); successes and bands only")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="write (add or replace) this machine's pin")
    ap.add_argument("--supersede", action="store_true",
                    help="with --write: drop every other machine's pin (after a deliberate change of the runs)")
    ap.add_argument("--only", default=None,
                    help=f"comma-separated pinned runs to re-run and compare (of {', '.join(RUNS)}; default all)")
    args = ap.parse_args(argv)
    if args.supersede and not args.write:
        ap.error("--supersede: only with --write")
    only = tuple(args.only.split(",")) if args.only else None
    if only and args.write:
        ap.error("--only: not with --write (a pin holds every run)")
    if only and any(n not in RUNS for n in only):
        ap.error(f"--only: expected some of {', '.join(RUNS)}, got {args.only!r}")
    from benchmarks.numerics import fingerprint
    from clients.provenance import provenance

    torch.set_num_threads(1)  # before provenance() and fingerprint(): they record the threads measure() runs with
    meta = provenance()
    here = fingerprint()
    measured = measure(only)
    stored = json.loads(PIN.read_text()) if PIN.exists() else {}
    pins = stored.get("machines", {})
    if args.write:
        key = pin_key(meta["machine"], here)
        pins, superseded = written_pins(pins, key, {"provenance": meta, "fingerprint": here, "runs": measured},
                                        supersede=args.supersede, superseded=stored.get("superseded", {}),
                                        commit=meta["commit"])
        out = {"provenance": meta, "machines": pins, **({"superseded": superseded} if superseded else {})}
        PIN.write_text(json.dumps(out, indent=2) + "\n")
        dropped = f"; superseded {sorted(superseded)}" if args.supersede and superseded else ""
        print(f"wrote the pin of {key!r} to {PIN}{dropped}")
        return 0
    result = compare(pins, measured, here)
    for line in result.differences:
        print(line)
    print(f"regression: {result.note}: " + ("identical" if not result.differences
                                            else f"{len(result.differences)} difference(s)"))
    return 1 if result.differences else 0


if __name__ == "__main__":
    sys.exit(main())
