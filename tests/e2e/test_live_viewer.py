"""Live viewing (`acnmp up --viewer`, LocalDeployment(viewer=True)): the recorder also streams what
it records over Rerun's gRPC server; a real Rerun client (the `rerun` command, saving what it
receives) gets a job's roll-outs while the job runs, and the web viewer's page loads in headless
Chromium."""
from __future__ import annotations

import shutil
import subprocess
import time
import urllib.request
from pathlib import Path
from urllib.parse import urlparse

import numpy as np
import pytest
import rerun as rr

from acnmp_core.experiments.viapoint import make_setup
from services.launcher import LocalDeployment
from services.recording.live_client import saving_client
from services.transport import call
from tests.unit.services.recording.test_web_viewer import listening_addresses

NS = "live"


def _entities(path: Path) -> set[str]:
    if not path.exists() or path.stat().st_size == 0:
        return set()
    try:
        reader = rr.chunk.RrdReader(path)
        return {c.entity_path for s in reader.recordings() for c in reader.stream(store=s)}
    except Exception:  # the client is still writing its first message
        return set()


def test_a_rerun_client_receives_the_rollouts_while_the_job_runs(tmp_path):
    setup = make_setup()
    tg = setup.target
    saved = tmp_path / "client.rrd"
    with LocalDeployment(NS, workers=1, model=False, record=tmp_path / "run.rrd", viewer=True,
                         state_dir=tmp_path / "state") as dep:
        assert dep.viewer_url.startswith("rerun+http://127.0.0.1:") and "live viewer" in dep.describe()
        with saving_client(dep.viewer_url, saved) as client:
            demos = setup.demos
            call(dep.session, dep.keys.train("e1"), {
                "times": np.stack([d.times for d in demos]), "values": np.stack([d.values for d in demos]),
                "model": {"encoder_widths": [32], "decoder_widths": [32]}, "train": {"steps": 100}}, timeout=60)
            job = call(dep.session, dep.keys.adapt("e1"), {
                "target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values, "query_times": tg.query_times},
                "task": "viapoint", "task_config": setup.task_config, "robot": "point2d",
                "config": {"max_rollouts": 12, "stop_on_success": False}}, timeout=10)["job"]
            deadline = time.monotonic() + 60
            while f"/rollouts/{job}" not in (seen := _entities(saved)):
                assert client.poll() is None and time.monotonic() < deadline, (seen, client.stderr.read1(4000))
                time.sleep(0.2)
            assert "/metrics/e1/train/nll" in seen and f"/jobs/{job}" in seen
            page = urllib.request.urlopen(dep.web_viewer_url, timeout=10).read().decode()
            assert "Rerun" in page and "<html" in page
            # on 127.0.0.1 only, as `acnmp up --help` says (rerun.serve_web_viewer listened on 0.0.0.0)
            assert listening_addresses(urlparse(dep.web_viewer_url).port) == {"0100007F"}
            chromium = shutil.which("chromium") or shutil.which("chromium-browser")
            if chromium is not None:  # the page's scripts run headless; the DOM names the viewer's app
                dom = subprocess.run([chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
                                      "--virtual-time-budget=5000", "--dump-dom", dep.web_viewer_url],
                                     capture_output=True, text=True, timeout=60)
                assert dom.returncode == 0 and "<canvas" in dom.stdout, dom.stderr[-2000:]
    if shutil.which("chromium") is None and shutil.which("chromium-browser") is None:
        pytest.skip("the gRPC stream was received; no chromium here to load the web viewer headless")
