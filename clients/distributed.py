"""The paper's experiments run across a local deployment (``acnmp experiment ... --distributed``).

An application above the services: it starts a deployment (services/launcher), talks to it as a
client (:class:`~clients.client.ACNMPClient`) and publishes roll-outs for the recorder.

E2 and E3 drive their loops in this process and only execute roll-outs remotely:
:func:`remote_rollouts` starts workers (and a recorder) and hands out evaluators that send the
roll-outs to the workers and publish each one for the recording.

E1 runs as a client of the services: the learner trains the skill from the demonstrations and runs
one adaptation job per method, the jobs' roll-outs go to the workers, the recorder logs every one,
and the assimilated model is read back through the model service. The learner calls the same
library functions with the same seeds as :func:`acnmp_core.experiments.viapoint.run_viapoint`,
so the numbers are the same as in one process.
"""
from __future__ import annotations

import itertools
import os
import time
from contextlib import contextmanager
from typing import Callable, Iterator

import numpy as np
from tqdm.auto import tqdm

from acnmp_core.adapt_job import AdaptJob
from acnmp_core.experiments.viapoint import (
    ASSIMILATION_STEPS, METHODS, ViaPointRun, ViaPointSetup, adapt_config, make_setup,
)
from acnmp_core.tasks.viapoint import shape_error
from clients.client import ACNMPClient
from services.launcher import LocalDeployment
from services.recording.publisher import EventPublisher
from services.recording.recorded import RecordedEvaluator
from services.worker.remote import RemoteEvaluator

SKILL = "e1"


@contextmanager
def remote_rollouts(robot: str, task: str, *, workers: int = 2, record: str | None = None,
                    prefix: str = "exp", progress: bool = True) -> Iterator[Callable[..., object]]:
    """Start ``workers`` workers of ``robot`` (and a recorder writing ``record`` when given) on a
    fresh local deployment; yield ``make(job, task_config=None)``, which returns an evaluator that
    executes roll-outs of ``task`` on those workers (with fail-over) and, when recording, publishes
    every roll-out under the job name ``<job>-<n>`` (n counts the evaluators made, so repeated runs
    of one method never share roll-out indices). Everything stops when the block exits."""
    ns = f"{prefix}-{os.getpid()}"
    with LocalDeployment(ns, workers=workers, robot=robot, record=record, model=False, learner=False) as dep:
        if progress:
            print(dep.describe(), flush=True)
        publisher = None
        if record:
            publisher = EventPublisher(dep.session, dep.keys)
            if not publisher.wait_for_recorder(timeout=30):
                raise RuntimeError(f"the recorder of deployment {ns!r} did not come up")
        counter = itertools.count()

        def make(job: str, task_config: dict | None = None):
            remote = RemoteEvaluator(dep.session, dep.keys, robot, task, task_config)
            if publisher is None:
                return remote
            return RecordedEvaluator(remote, publisher, f"{job}-{next(counter)}", robot)

        yield make


def _adapt_job(setup: ViaPointSetup, method: str, budget: int, seed: int, overrides: dict) -> AdaptJob:
    """The learner's adaptation job equivalent to the in-process E1 run of ``method``."""
    return AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, adapt_config(method, budget, **overrides),
                    seed=seed, commit=method == "acnmp", assimilate_steps=ASSIMILATION_STEPS)


def _latents(client: ACNMPClient, demos) -> np.ndarray:
    """(N, L) latent of each demonstration as the model service encodes it from all its points."""
    return np.stack([client.predict(SKILL, d.times, d.values, None, d.times[:1], timeout=30).latent for d in demos])


def _reproduction(client: ACNMPClient, demos, n_obs: int = 3) -> float:
    """Same measure as acnmp_core.training.reproduction_error, through the model service."""
    errs = []
    for d in demos:
        idx = np.linspace(0, len(d.times) - 1, n_obs).round().astype(int)
        pred = client.predict(SKILL, d.times[idx], d.values[idx], None, d.times, timeout=30)
        errs.append(np.mean((pred.mean - d.values) ** 2))
    return float(np.sqrt(np.mean(errs)))


def _wait_version(client: ACNMPClient, version: int, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if client.info(SKILL)["version"] >= version:
                return
        except Exception:  # the model service may not have the skill yet
            pass
        time.sleep(0.2)
    raise TimeoutError(f"the model service did not serve version {version} of {SKILL!r} in {timeout:.0f} s")


def run_viapoint_distributed(seed: int = 0, variant: str = "2d", *, budget: int = 100, train_steps: int = 3000,
                             workers: int = 2, record: str | None = None, progress: bool = True,
                             adapt_overrides: dict | None = None) -> ViaPointRun:
    """Run E1 on a fresh local deployment (``workers`` point-mass workers, a recorder writing
    ``record`` when given). Returns a :class:`ViaPointRun` like the in-process run."""
    overrides = dict(adapt_overrides or {})
    t0 = time.perf_counter()
    setup = make_setup(variant)
    demos, task = setup.demos, setup.task
    ns = f"e1-{os.getpid()}"
    with LocalDeployment(ns, workers=workers, robot="point2d", record=record) as dep, \
            ACNMPClient(ns, session=dep.session, timeout=30) as client:
        if progress:
            print(dep.describe(), flush=True)
        arrays = np.stack([d.values for d in demos])
        reply = client.train(SKILL, demos[0].times, arrays, train={"steps": train_steps}, seed=seed, timeout=600)
        _wait_version(client, reply["version"])
        latents_before = _latents(client, demos)
        repro_before = _reproduction(client, demos)
        methods, trajs, curves = {}, {}, {}
        for method in tqdm(METHODS, desc="jobs", disable=not progress):
            job = client.adapt(SKILL, _adapt_job(setup, method, budget, seed, overrides))
            status = client.wait_job(job, timeout=1800, progress=False)
            if status["state"] != "done":
                raise RuntimeError(f"job {job} ({method}) ended {status['state']}: {status.get('error')}")
            res = status["result"]
            traj, times = np.asarray(res["trajectory"]), np.asarray(res["times"])
            err = float(task.errors(traj[None], times)[0])
            methods[method] = {"rollouts": int(res["rollouts"]), "success": bool(err <= task.tolerance),
                               "error": err, "shape_error": shape_error(traj, times, demos), "job": job}
            trajs[method] = traj
            curves[method] = [(h["rollouts"], -h["mean_return"]) for h in res["history"]]
            if method == "acnmp" and status.get("committed_version") is not None:
                _wait_version(client, int(status["committed_version"]))
        assim = {"performed": False}
        latents_after = latents_before
        if methods["acnmp"]["success"]:
            t = setup.target
            pred = client.predict(SKILL, t.obs_times, t.obs_values, None, t.query_times)
            new_demos = demos.added(type(demos[0])(t.query_times, trajs["acnmp"]))
            assim = {
                "performed": True, "n_demos": len(new_demos),
                "viapoint_error_after": float(task.errors(pred.mean[None], t.query_times)[0]),
                "old_demos_reproduction_rmse_before": repro_before,
                "old_demos_reproduction_rmse_after": _reproduction(client, demos),
                "solution_reproduction_rmse": _reproduction(client, new_demos.subset([len(demos)])),
            }
            latents_after = _latents(client, new_demos)
    summary = {
        "experiment": "viapoint", "variant": variant, "seed": int(seed), "distributed": True,
        "workers": int(workers), "recording": str(record) if record else None,
        "wall_time_s": round(time.perf_counter() - t0, 2), "tolerance": task.tolerance,
        "demo_extent": demos.extent(),
        "viapoint": {"t": float(setup.target.obs_times[0]), "value": setup.target.obs_values[0].tolist()},
        "methods": methods, "lfd_reproduction_rmse": repro_before, "assimilation": assim,
    }
    return ViaPointRun(summary, demos, trajs, setup.target.query_times,
                       (float(setup.target.obs_times[0]), setup.target.obs_values[0]),
                       latents_before, latents_after, curves)
