"""10,000 generated hostile requests through a real zenoh session to a whole local deployment (issue 12).

The deployment and the requests are those of the hostile-input suite (benchmarks/performance/hostile_inputs.py:
learner, model service, one point2d worker, recorder; random bytes, arbitrary msgpack, hand-made
array maps, NaN, unknown versions, mutated valid requests), ``--requests`` in all, shared equally by
the eight queryables. Reported: answers per code (``ok`` or an error code), the share that is a
success or a documented code other than ``internal`` (``timeout`` and no reply count against it),
processes that died, and the model service's peak resident set (sampled with psutil every 20 ms,
and the kernel's VmHWM at the end). Target: 100 % documented, 0 crashes, peak RSS < 1 GiB.

    python benchmarks/performance/bench_hostile.py [--requests 10000] [--out benchmarks/results/bench_hostile.json]
"""
from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import main_provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402


class RssSampler:
    """Samples the resident set of process ``pid`` every ``period`` seconds on a thread; ``peak``
    is the largest seen, bytes."""

    def __init__(self, pid: int, period: float = 0.02):
        import psutil

        self._proc = psutil.Process(pid)
        self._period = period
        self._stop = threading.Event()
        self.peak = 0
        self._thread = threading.Thread(target=self._run, name="rss-sampler", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self.peak = max(self.peak, self._proc.memory_info().rss)
            except Exception:  # the process is gone: reported as a crash by the caller
                return
            self._stop.wait(self._period)

    def stop(self) -> int:
        """Stop sampling; returns the peak (bytes)."""
        self._stop.set()
        self._thread.join(timeout=5)
        return self.peak


def send_all(dep, per_queryable: int) -> dict[str, collections.Counter]:
    """Send ``per_queryable`` generated requests to each queryable of ``dep``; returns name ->
    Counter of answer codes (``ok``, an error code, ``no_reply``). Never raises on an answer."""
    from hypothesis import HealthCheck, Phase, given, seed, settings

    from benchmarks.performance.hostile_inputs import payloads, queryables
    from services.transport.wire import WireError, error_from_payload

    counts: dict[str, collections.Counter] = {}
    for name, (key, base) in queryables(dep.keys).items():
        codes: collections.Counter = collections.Counter()

        def send(payload) -> None:
            if sum(codes.values()) >= per_queryable:  # hypothesis may call once more than asked
                return
            replies = list(dep.session.get(key, payload=payload, timeout=30))
            if not replies:
                codes["no_reply"] += 1
            for reply in replies[:1]:  # one answer per request (each queryable has one server)
                if reply.ok is not None:
                    codes["ok"] += 1
                    continue
                try:
                    codes[error_from_payload(reply.err.payload.to_bytes()).code] += 1
                except WireError as exc:  # an error reply that is not ours at all
                    codes[f"unparsed:{exc.code}"] += 1

        rnd = 0
        while sum(codes.values()) < per_queryable:  # hypothesis may stop short: top up with new seeds
            run = settings(max_examples=per_queryable - sum(codes.values()), deadline=None, database=None,
                           phases=[Phase.generate], suppress_health_check=list(HealthCheck))(
                given(payloads(base))(send))
            seed(rnd)(run)()
            rnd += 1
        counts[name] = codes
        print(f"{name:16s} {sum(codes.values())} requests: {dict(codes)}", flush=True)
    return counts


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the summary and write the JSON. Exit code 0 if the targets are met,
    1 otherwise."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--requests", type=int, default=10_000, help="hostile requests in all (default: %(default)s)")
    add_run_arguments(p, out="benchmarks/results/bench_hostile.json")
    args = p.parse_args(argv)
    if args.requests < 8:
        p.error("--requests: at least 8 (one per queryable)")

    from benchmarks.performance.hostile_inputs import MODEL_RSS_BOUND, hostile_deployment, peak_rss, served
    from services.transport import ERROR_CODES

    prov = main_provenance(__file__, argv)
    per = args.requests // 8
    with tempfile.TemporaryDirectory(prefix="bench-hostile-") as tmp, hostile_deployment(Path(tmp)) as dep:
        model_pid = dep.children["model"].pid
        sampler = RssSampler(model_pid)
        t0 = time.perf_counter()
        counts = send_all(dep, per)
        seconds = time.perf_counter() - t0
        rss_sampled = sampler.stop()
        dead = sorted(c.name for c in dep.children.values() if c.proc.poll() is not None)
        try:
            still_serving = served(dep)["mean"].shape == (20, 2)
        except Exception:
            still_serving = False
        rss_hwm = peak_rss(model_pid) if not dead or "model" not in dead else None

    total = collections.Counter()
    for c in counts.values():
        total.update(c)
    answers = sum(total.values())
    good = sum(n for code, n in total.items() if code == "ok" or (code in ERROR_CODES and code not in ("internal", "timeout")))
    peak = max(rss_sampled, rss_hwm or 0)
    result = {
        "benchmark": "hostile", "provenance": prov, "requests": per * 8, "answers": answers,
        "seconds": seconds, "codes": dict(sorted(total.items())),
        "codes_by_queryable": {name: dict(sorted(c.items())) for name, c in counts.items()},
        "documented_pct": 100.0 * good / answers if answers else 0.0,
        "undocumented": {code: n for code, n in total.items()
                         if not (code == "ok" or (code in ERROR_CODES and code not in ("internal", "timeout")))},
        "crashed": dead, "crashes": len(dead), "still_serving": still_serving,
        "model_peak_rss_bytes": peak, "model_peak_rss_mib": peak / 2**20,
        "model_peak_rss_sampled_bytes": rss_sampled, "model_vmhwm_bytes": rss_hwm,
        "rss_bound_bytes": MODEL_RSS_BOUND,
        "targets": "100 % documented codes, 0 crashes, model-service peak RSS < 1 GiB",
    }
    result["targets_met"] = bool(result["documented_pct"] == 100.0 and not dead and still_serving
                                 and peak < MODEL_RSS_BOUND)
    save_result(result, args.out, headline=("requests", "documented_pct", "crashes", "model_peak_rss_mib",
                                            "targets_met", "seconds"))
    return 0 if result["targets_met"] else 1


if __name__ == "__main__":
    sys.exit(main())
