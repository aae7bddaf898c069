"""An authenticated deployment (``LocalDeployment(secure=True)``, what ``acnmp up`` starts, and
what ``acnmp experiment ... --distributed`` starts by default): zenoh user/password on every link
and the router's ACL (services/transport/auth.py)."""
from __future__ import annotations

import stat

import numpy as np
import pytest
import zenoh

from acnmp_core import CNMP, CNMPConfig, TrainConfig, train
from clients.client import ACNMPClient, ClientError
from clients.distributed import experiment_deployment
from services.launcher import LocalDeployment
from services.model.weights import encode_weights
from services.transport import WireError, call, decode, open_session
from services.transport.runfile import DeploymentNotFound, find

NS = "sec"
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
FORGED_VERSION = 2**62


def _weights(demos, version: int, data_hash: str, seed: int) -> bytes:
    """A valid weights message for skill ``s`` (a small CNMP trained one step)."""
    model = CNMP(CNMPConfig(n_outputs=2, **SMALL), seed=seed)
    train(model, demos, TrainConfig(steps=1), seed=seed)
    return encode_weights("s", version, model, data_hash=data_hash, n_demos=1)


@pytest.fixture(scope="module")
def forged_weights(e1_demos) -> bytes:
    """A valid weights message for skill ``s`` at version 2^62, as an attacker sends it."""
    return _weights(e1_demos, FORGED_VERSION, "forged", seed=3)


def _train(client: ACNMPClient, demos, seed: int) -> int:
    reply = client.train("s", demos[0].times, np.stack([d.values for d in demos]), model=SMALL,
                         train={"steps": 20}, seed=seed, timeout=60)
    return int(reply["version"])


def _wait_served(client: ACNMPClient, version: int, timeout: float = 30.0) -> dict:
    """Wait until the model service serves ``version`` or later of ``s`` (info polled through
    the client's retries); returns the info."""
    import time

    end = time.monotonic() + timeout
    while True:
        try:
            info = client.info("s", timeout=max(0.5, end - time.monotonic()))
            if info["version"] >= version or time.monotonic() > end:
                return info
        except ClientError:
            if time.monotonic() > end:
                raise
        time.sleep(0.1)


def _outsider_is_shut_out(dep: LocalDeployment, forged_weights: bytes) -> None:
    """A process without the deployment's secret: as a peer it opens (and keeps retrying) but the
    router refuses its link, so its put of forged weights goes nowhere and its query finds no
    queryable (``unavailable``); as a client it cannot even open."""
    with open_session("peer", connect=[dep.anchor], open_timeout=3) as outsider:
        outsider.put(dep.keys.weights("s"), forged_weights)
        with pytest.raises(WireError) as err:
            call(outsider, dep.keys.info("s"), None, 2.0)
        assert err.value.code == "unavailable"
    with pytest.raises(ConnectionError):
        with open_session("client", connect=[dep.anchor], open_timeout=1):
            pass


def test_an_experiment_deployment_is_authenticated_by_default(tmp_path, e1_demos, forged_weights):
    """``acnmp experiment ... --distributed`` starts its deployment through experiment_deployment:
    authenticated with the secrets in its state directory, not announced; an outsider can neither
    query it nor put weights into it."""
    state = tmp_path / "state"
    with experiment_deployment("sec-exp", workers=0, learner=False, state_dir=state, start_timeout=90) as dep:
        assert dep.secure
        secrets = state / "secrets"
        assert stat.S_IMODE(secrets.stat().st_mode) == 0o700
        assert {stat.S_IMODE(f.stat().st_mode) for f in secrets.iterdir()} == {0o600}
        with pytest.raises(DeploymentNotFound):  # private to the run: `acnmp query` never finds it
            find(dep.namespace)
        _outsider_is_shut_out(dep, forged_weights)
        # the experiment's own session (the router) is heard: weights it puts at version 0 are
        # served, which they would not be had the forged version 2^62 arrived first
        dep.session.put(dep.keys.weights("s"), _weights(e1_demos, 0, "genuine", seed=4))
        with ACNMPClient(dep.namespace, session=dep.session, timeout=30) as client:
            info = _wait_served(client, 0)
        assert info["version"] == 0 and info["data_hash"] == "genuine" and info["source"] == "learner"
    assert not secrets.exists()  # the passwords went with the deployment


def test_without_the_secret_nothing_and_with_client_credentials_no_weights(e1_demos, forged_weights):
    with LocalDeployment(NS, workers=0, secure=True, start_timeout=90) as dep:
        run = find(NS)
        assert run.anchor == dep.anchor and run.credentials
        with ACNMPClient(role="operator", timeout=30) as operator:  # found by the run file
            assert operator.namespace == NS
            assert _wait_served(operator, _train(operator, e1_demos, seed=1))["version"] == 0

            # 1. no secret: no link, so no query and no put
            _outsider_is_shut_out(dep, forged_weights)
            # ... nor with a wrong password
            cfg = zenoh.Config.from_file(run.credentials)
            cfg.insert_json5("transport/auth/usrpwd/password", '"guessed"')
            with pytest.raises(ConnectionError):
                with open_session(config=cfg, open_timeout=1):
                    pass

            # 2. the client's credentials: queries work, weights, jobs and fake answers do not
            with open_session(None, config_file=run.credentials) as client:
                assert call(client, dep.keys.info("s"), None, 5.0)["version"] == 0
                client.put(dep.keys.weights("s"), forged_weights)
                fake = client.declare_queryable(dep.keys.info("s"), lambda q: q.reply(q.key_expr, b"fake"))
                for key in (dep.keys.train("s"), dep.keys.train_pair("s")):
                    with pytest.raises(WireError) as err:  # starting a job: the router drops the query
                        call(client, key, {"v": 1}, 2.0)
                    assert err.value.code == "unavailable", key
                # every answer to info comes from the model service, none from the fake queryable
                replies = list(operator.session.get(dep.keys.info("s"), target=zenoh.QueryTarget.ALL, timeout=3))
                assert replies and all(r.ok is not None for r in replies)
                assert {decode(r.ok.payload.to_bytes())["data_hash"] != "forged" for r in replies} == {True}
                fake.undeclare()

            # 3. the operator's credentials do not carry weights either
            operator.session.put(dep.keys.weights("s"), forged_weights)

            # the learner's next version replaces version 0: had any forged 2^62 been taken, it never would
            info = _wait_served(operator, _train(operator, e1_demos, seed=2))
            assert info["version"] == 1 and info["data_hash"] != "forged" and info["source"] == "learner"
    with pytest.raises(OSError):  # the run file went with the deployment
        find(NS)
