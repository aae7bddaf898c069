"""``acnmp query predict|transfer|info|skills|cancel`` (and ``train|adapt|jobs|watch``, clients/commands/jobs.py):
ask a running deployment from the shell."""
from __future__ import annotations

import argparse
import json

import numpy as np

from services.transport.argtypes import int_at_least
from services.transport import jsonable

from .common import NO_MODEL_SERVICE, _ask, _client, _common, _fail, _floats, _skill, condition_arguments, parse_obs, parse_obs_json

EPILOG = """\
examples:
  acnmp query skills                        # the deployment `acnmp up` runs (found by its run file)
  acnmp query skills --namespace lab        # one of several: `acnmp status` lists them
  acnmp query info                          # the deployment's one skill (after `acnmp up`: e1)
  acnmp query info --skill reach
  acnmp query predict --skill reach --obs 0:0.0,0.0 --obs 1:1.0,0.2 --steps 200
  acnmp query predict --skill push --obs 0:0.1,0.2,_ --task-params 0.4,0.3 --times 0,0.5,1 --json
  acnmp query predict --skill reach --obs-json '[[0.0, [0.0, 0.0]]]' --samples 5 --seed 1
  acnmp query transfer --skill e4 --obs 0:0.1,0.5,0.2 --obs 1:0.3,0.4,0.1 --steps 300   # robot A in, B out

An observation is TIME:V1,V2,... with one value per output dimension; write _ for a dimension the
observation does not carry (it is masked out). Without --connect or --config the command finds
the running deployment of --namespace (or the only one running) by the run file `acnmp up`
writes, with its client credentials; $ACNMP_CONNECT (e.g. tcp/127.0.0.1:7447 for the compose
router) skips that.
"""


def register(subparsers) -> None:
    """Add ``query`` with the ``predict``, ``transfer``, ``info``, ``skills`` and ``cancel`` sub-commands."""
    parser = subparsers.add_parser(
        "query", help="ask a running deployment (predict, transfer, info, skills; train, adapt, jobs, watch, cancel)",
        description="Ask a running deployment over zenoh: its model service (predict, transfer, info,\n"
                    "skills) or its learner (train a skill, adapt one, list, follow or cancel jobs).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="query_command", metavar="WHAT", required=True)

    predict = sub.add_parser("predict", help="condition a skill on observations and predict a trajectory",
                             description="Condition a skill on observations (and task parameters) and print the "
                                         "predicted mean and std per step.",
                             epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    _prediction_arguments(predict, task_params=True)
    predict.set_defaults(func=_run_predict)

    transfer = sub.add_parser("transfer", help="robot B's trajectory for robot A's observations (a paired skill)",
                              description="Encode robot A's observations with a paired skill's encoder A and "
                                          "decode robot B's trajectory with its decoder B (skill transfer); print "
                                          "B's mean and std per step and the latent.",
                              epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    _prediction_arguments(transfer, task_params=False)
    transfer.set_defaults(func=_run_transfer)

    info = sub.add_parser("info", help="describe a served skill (dimensions, names, ranges, version)",
                          description="Describe the model serving a skill.")
    _common(info)
    info.set_defaults(func=_run_info)

    skills = sub.add_parser("skills", help="list the skills some model service has weights for",
                            description="List the skills that have a live model service (liveliness tokens).")
    _common(skills, skill=False)
    skills.set_defaults(func=_run_skills)

    cancel = sub.add_parser("cancel", help="cancel an adaptation job on the learner",
                            description="Cancel a job: a queued one at once, a running one after its current "
                                        "iteration (saved as cancelled). Prints the job's state.")
    _common(cancel, skill=False)
    cancel.add_argument("job", metavar="JOB", help="job id (as the adapt reply gave it)")
    cancel.set_defaults(func=_run_cancel)

    from . import jobs  # train, adapt, jobs, watch: the learner's work

    jobs.add_job_commands(sub)


def _prediction_arguments(parser: argparse.ArgumentParser, task_params: bool) -> None:
    """The options of ``predict`` and ``transfer``: observations, query times, samples."""
    _common(parser)
    condition_arguments(parser, task_params)
    parser.add_argument("--samples", type=int_at_least(0), default=None, metavar="S",
                        help="also draw S sampled trajectories")
    parser.add_argument("--seed", type=int_at_least(0, hi=2**64 - 1), default=None,  # the wire's uint64
                        help="seed of the samples")


def _run_predict(args) -> int:
    task_params = _floats(args.task_params, "--task-params")  # refused before any session opens
    return _run_prediction(args, lambda client, skill, **kw: client.predict(skill, task_params=task_params, **kw))


def _run_transfer(args) -> int:
    return _run_prediction(args, lambda client, skill, **kw: client.transfer(skill, **kw))


def _run_prediction(args, ask) -> int:
    """Parse the observations and query times of ``args``, ``ask(client, skill, obs_times=,
    obs_values=, query_times=, n_steps=, obs_dims_mask=, n_samples=, seed=)`` for a
    :class:`~clients.client.PredictResult`, print it (a table, or ``--json``)."""
    from clients.client import ClientError

    if args.obs_json:
        times, values, mask = parse_obs_json(args.obs_json)
    else:
        times, values, mask = parse_obs(args.obs)
    query_times = _floats(args.times, "--times")
    n_steps = None if query_times is not None else (100 if args.steps is None else args.steps)
    with _client(args) as client:
        try:
            p = ask(client, _skill(args, client), obs_times=times, obs_values=values, query_times=query_times,
                    n_steps=n_steps, obs_dims_mask=None if mask.all() else mask, n_samples=args.samples,
                    seed=args.seed)
        except ClientError as exc:
            return _fail(exc)
    if args.json:
        out = {"skill": p.skill, "version": p.version, "times": p.times, "mean": p.mean, "std": p.std,
               "latent": p.latent}
        if p.samples is not None:
            out["samples"] = p.samples
        print(json.dumps(jsonable(out)))
        return 0
    steps, dims = p.mean.shape
    print(f"skill {p.skill} version {p.version}: {steps} steps x {dims} dims (mean ± std); "
          f"latent {p.latent.shape[0]}-D" + (f"; {p.samples.shape[0]} samples (use --json)" if p.samples is not None else ""))
    shown = np.unique(np.linspace(0, steps - 1, min(steps, 11)).round().astype(int))
    for i in shown:
        cells = "  ".join(f"{m:+.4f} ± {s:.4f}" for m, s in zip(p.mean[i], p.std[i]))
        print(f"  t={p.times[i]:<8.4g} {cells}")
    if len(shown) < steps:
        print(f"  ({len(shown)} of {steps} steps shown; --json prints all)")
    return 0


def _run_info(args) -> int:
    info, code = _ask(args, lambda client: client.info(_skill(args, client)))
    if info is None:
        return code
    print(f"skill {info['skill']} version {info['version']} ({info['source']})")
    print(f"  outputs ({info['n_outputs']}): {', '.join(info['output_names'])}")
    lo, hi = info["value_low"], info["value_high"]
    for name, a, b in zip(info["output_names"], lo, hi):
        print(f"    {name}: demos span [{a:g}, {b:g}]")
    print(f"  task parameters ({info['n_task_params']}): {', '.join(info['task_param_names']) or 'none'}")
    for name, a, b in zip(info["task_param_names"], info["task_param_low"], info["task_param_high"]):
        print(f"    {name}: [{a:g}, {b:g}]")
    print(f"  time range: [{info['time_range'][0]:g}, {info['time_range'][1]:g}]; latent dim {info['latent_dim']}")
    print(f"  trained on {info['n_demos']} demos, data hash {info['data_hash'][:16] or '-'}")
    print(f"  model: {_model_line(info['config'])}")
    partner = info.get("partner")
    if partner:
        print(f"  paired skill: `acnmp query transfer` answers robot B's {partner['n_outputs']} outputs "
              f"({', '.join(partner['output_names'])}) for these {info['n_outputs']} of robot A")
    return 0


def _model_line(config: dict) -> str:
    """The skill's model in one line: which one and, when its demonstrations chose it, why."""
    choice = config.get("prior_choice")
    if choice:
        return choice["reason"]
    named = {"linear": "the linear path beside the network", "none": "the network alone (the paper's CNMP)",
             "trend": "the network with the demonstrations' linear trend beyond its range"}
    return f"{named.get(config.get('prior', 'none'), config.get('prior'))} (as the training request set it)"


def _run_skills(args) -> int:
    with _client(args) as client:
        names = client.skills()
        reachable = bool(names) or client.model_services() > 0
    if args.json:
        print(json.dumps(names))
    elif names:
        print("\n".join(names))
    elif reachable:
        print("no skill is served yet (the model service is live, with no weights)")
    else:
        print(f"no skill is served: {NO_MODEL_SERVICE}")
    return 0


def _run_cancel(args) -> int:
    # the router's ACL lets only the operator (and the learner) cancel (docs/SECURITY.md):
    # with the client's credentials the query is dropped and times out as `unavailable`
    status, code = _ask(args, lambda client: client.cancel(args.job), role="operator")
    if status is None:
        return code
    pending = " (cancel requested: it stops after its current iteration)" if status["state"] == "running" else ""
    print(f"job {status['job']}: {status['state']}{pending}")
    return 0
