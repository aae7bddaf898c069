"""E4 across a local deployment (``acnmp experiment transfer --distributed``): the services' shape.

An application above the services, like clients/distributed.py: it starts a deployment with a
learner, a model service, ``planar4`` workers and (with ``--record``) a recorder, and runs
:func:`acnmp_core.experiments.transfer.run_transfer` with

* the **pairs trained by the learner**: per pair seed, two ``train_pair`` jobs (skills
  ``e4-aligned-<seed>`` and ``e4-plain-<seed>``, the latter without the alignment term) with the
  seeds the in-process run uses; the pair is rebuilt from the weights the learner publishes
  (``weights/latest``), so the RL in robot B starts from the learner's pair;
* **robot B's first attempt from the model service**: the transfer query on the aligned (or
  plain) skill with robot A's observations, compared with the trajectory the RL starts from
  (``first_attempt_diff`` per run: 0 when they are the same);
* robot B's roll-outs on the workers, each recorded with robot A's demonstration drawn beside it.

The learner trains with the library's :func:`~acnmp_core.transfer.pair.train_pair`, one torch thread,
the same seeds: the numbers are those of the in-process run (tests/e2e/test_transfer_service.py).
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import replace
from typing import Iterator

import numpy as np

from acnmp_core.adaptation.config import AdaptTarget
from acnmp_core.experiments.transfer import E4Setup, TransferExperimentConfig, run_transfer, task_config
from acnmp_core.jobs.transfer import PairTrainJob
from acnmp_core.robots.registry import robot
from acnmp_core.transfer.pair import TransferPair
from clients.client import ACNMPClient
from clients.distributed import EvaluatorMaker, attach, experiment_deployment, patiently, started_facts

ROBOT_A, ROBOT_B = "planar3", "planar4"
#: Seconds a pair job may take (3000 steps: about a minute on a loaded core).
PAIR_TIMEOUT = 1800.0


def pair_skill(name: str, seed: int) -> str:
    """The skill a pair of kind ``name`` (``aligned``/``plain``) and pair seed ``seed`` is trained as."""
    return f"e4-{name}-{seed}"


class DeployedPairs:
    """E4's transfer pairs on a deployment: trained by its learner, queried on its model service.

    :meth:`train` is a :data:`~acnmp_core.experiments.transfer.PairTrainer`, :meth:`first_attempt`
    gives the :data:`~acnmp_core.experiments.transfer.FirstAttempt` of a pair seed.
    """

    def __init__(self, client: ACNMPClient, progress: bool = False):
        self.client, self.progress = client, progress
        self.jobs: dict[str, str] = {}  # skill -> job id

    def train(self, setup: E4Setup, cfg: TransferExperimentConfig, seed: int) -> dict[str, TransferPair]:
        """The ``aligned`` and ``plain`` pairs of pair seed ``seed``, trained by the learner as
        ``train_pair`` jobs and rebuilt from its weights."""
        out = {}
        for name, weight in (("aligned", cfg.pair.latent_weight), ("plain", 0.0)):
            skill = pair_skill(name, seed)
            job = PairTrainJob(setup.demos_a, setup.demos_b, replace(cfg.pair, latent_weight=weight), seed=seed,
                               robot_a=ROBOT_A, robot_b=ROBOT_B)
            job_id = patiently(lambda: self.client.train_pair(skill, job), "train_pair", progress=self.progress)
            self.jobs[skill] = job_id
            status = self.client.wait_job(job_id, timeout=PAIR_TIMEOUT, progress=self.progress)
            if status["state"] != "done":
                raise RuntimeError(f"pair job {job_id} ({skill}) ended {status['state']}: {status.get('error')}")
            weights = patiently(lambda: self.client.weights(skill), "weights", progress=self.progress)
            out[name] = TransferPair.from_models(weights.model, weights.partner)
        return out

    def first_attempt(self, seed: int):
        """``(condition, target) -> (T, 4)``: the model service's transfer of ``target``'s robot A
        observations with the pair of seed ``seed`` (None for ``no_transfer``, which has no transfer)."""
        def ask(condition: str, target: AdaptTarget) -> np.ndarray | None:
            if condition == "no_transfer":
                return None
            skill = pair_skill("aligned" if condition == "transfer" else "plain", seed)
            return patiently(lambda: self.client.transfer(skill, target.obs_times, target.obs_values,
                                                          target.query_times, timeout=30),
                             "transfer", progress=self.progress).mean
        return ask


@contextmanager
def transfer_deployment(workers: int = 2, record: str | None = None, progress: bool = True,
                        secure: bool = True, namespace: str | None = None,
                        config: str | None = None) -> Iterator[tuple[DeployedPairs, object]]:
    """A fresh local deployment for E4 (learner, model service, ``workers`` planar4 workers, a
    recorder writing ``record`` when given; authenticated unless ``secure`` is False,
    :func:`clients.distributed.experiment_deployment`), or the running one of ``namespace``
    (:func:`clients.distributed.attach`, through the zenoh ``config`` file when given; it needs
    planar4 workers, a learner and a model service);
    yields (:class:`DeployedPairs`, ``make(job, task_config, extra)``, a
    :class:`clients.distributed.EvaluatorMaker` whose ``deployment`` holds the deployment's facts)."""
    if namespace is not None:
        with attach(namespace, ROBOT_B, record=record, secure=secure, progress=progress, config=config) as joined:
            yield DeployedPairs(joined.client), EvaluatorMaker(joined, ROBOT_B, "cube_gap", joined.facts,
                                                               record=joined.events is not None)
        return
    with experiment_deployment("e4", secure=secure, workers=workers, robot=ROBOT_B, record=record) as dep, \
            ACNMPClient(dep.namespace, session=dep.session, timeout=30) as client:
        if progress:
            print(dep.describe(), flush=True)
        yield DeployedPairs(client), EvaluatorMaker(dep, ROBOT_B, "cube_gap", started_facts(dep, workers, record),
                                                    record=bool(record))


def run_transfer_distributed(runs, *, workers: int = 2, record: str | None = None, progress: bool = True,
                             secure: bool = True, namespace: str | None = None, config: str | None = None,
                             **kwargs) -> dict:
    """:func:`~acnmp_core.experiments.transfer.run_transfer` on a fresh deployment (see the module
    docstring; authenticated unless ``secure`` is False); ``kwargs`` go to it (``cfg``, ``authors_data``, ``log``, ...). Every roll-out of
    robot B is recorded with robot A's demonstration of the new skill drawn beside it. Returns its
    result with the ``deployment``'s facts (:class:`clients.distributed.DeploymentFacts`) and the
    pair jobs."""
    from acnmp_core.experiments.transfer import make_setup

    setup = make_setup()
    reference = {"reference_joint_angles": setup.new_a,
                 "reference_link_lengths": np.asarray(robot(ROBOT_A).drawing.event_fields()["link_lengths"])}
    with transfer_deployment(workers, record, progress, secure, namespace, config) as (pairs, make):
        result = run_transfer(runs, evaluator_factory=lambda cond: make(f"transfer-{cond}", task_config(), reference, method=cond),
                              pair_trainer=pairs.train, first_attempt=pairs.first_attempt, setup=setup, **kwargs)
    result.update(deployment=make.deployment.to_dict(), pair_jobs=dict(pairs.jobs))
    return result
