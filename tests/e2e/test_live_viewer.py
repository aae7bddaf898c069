"""Live viewing (`acnmp up --viewer`, LocalDeployment(viewer=True)): the recorder also streams what
it records over Rerun's gRPC server; a real Rerun client (the `rerun` command, saving what it
receives) gets a job's roll-outs while the job runs, and the web viewer's page, loaded in headless
Chromium as a user's browser loads it, draws them.

Chromium is Debian's package (`bash scripts/install_chromium.sh`, which `.ci/run` runs first): in CI
(`CI` set) a machine without it fails the test; elsewhere the browser half is skipped, saying why."""
from __future__ import annotations

import os
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
from services.recording.rrd_writer import _FAIL, _OK
from services.transport import call
from tests.e2e.browser import Chromium, chromium_path
from tests.unit.services.recording.test_web_viewer import listening_addresses

NS = "live"
#: how long the page may take to load the viewer (its 30 MB of WebAssembly) and draw, on a loaded machine
PAGE_TIMEOUT = 180.0


def _entities(path: Path) -> set[str]:
    if not path.exists() or path.stat().st_size == 0:
        return set()
    try:
        reader = rr.chunk.RrdReader(path)
        return {c.entity_path for s in reader.recordings() for c in reader.stream(store=s)}
    except Exception:  # the client is still writing its first message
        return set()


def rollout_pixels(image: np.ndarray) -> int:
    """How many pixels of ``image`` (H, W, 3) have the colour the recording draws a roll-out's path
    in (services/recording/rrd_writer.py: succeeded or failed), give or take anti-aliasing."""
    near = [np.all(np.abs(image.astype(int) - np.array(colour)) <= 24, axis=2) for colour in (_OK, _FAIL)]
    return int(np.count_nonzero(near[0] | near[1]))


def _viewer_state(page) -> bytes:
    """The viewer's own account of what it shows: the WebHandle's ``viewer_state()`` (a protobuf:
    the recordings open, the views of their blueprint with their names and origins)."""
    return bytes(page.evaluate("Array.from(window._handle.viewer_state())"))


def _drawn(page, want: int) -> np.ndarray:
    """The page's screenshot once it shows at least ``want`` roll-out pixels; TimeoutError after
    :data:`PAGE_TIMEOUT` with the last count."""
    deadline = time.monotonic() + PAGE_TIMEOUT
    while (count := rollout_pixels(shot := page.screenshot())) < want:
        if time.monotonic() > deadline:
            raise TimeoutError(f"the viewer drew {count} roll-out pixels after {PAGE_TIMEOUT:g} s (expected {want})")
        time.sleep(0.5)
    return shot


def test_a_rerun_client_receives_the_rollouts_while_the_job_runs_and_the_web_viewer_draws_them(tmp_path):
    setup = make_setup()
    tg = setup.target
    saved = tmp_path / "client.rrd"
    chromium = chromium_path()
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
        port = urlparse(dep.web_viewer_url).port
        assert listening_addresses(port) == {"0100007F"}
        if chromium is None:
            if os.environ.get("CI"):
                pytest.fail("CI: no chromium to load the web viewer (.ci/run installs Debian's with "
                            "scripts/install_chromium.sh; its output says why it could not)")
            pytest.skip("the gRPC stream was received; no chromium here to load the web viewer "
                        "(bash scripts/install_chromium.sh installs Debian's, as root)")
        with Chromium(1280, 800) as browser:
            # the same viewer with no recording: what the page shows when nothing is drawn
            empty = browser.open(f"http://127.0.0.1:{port}/?hide_welcome_screen")
            empty.wait_for("!!window._handle", PAGE_TIMEOUT)
            nothing = empty.screenshot()
            empty.close()
            viewer = browser.open(dep.web_viewer_url)
            viewer.wait_for("!!window._handle", PAGE_TIMEOUT)
            # the viewer's own state: this deployment's recording is open with the recorder's views
            deadline = time.monotonic() + PAGE_TIMEOUT
            wanted = (dep.recording_id.encode(), b"Trajectories (x, y)", b"/trajectory/xy")
            while not all(w in (state := _viewer_state(viewer)) for w in wanted):
                assert time.monotonic() < deadline, state
                time.sleep(0.5)
            # and drawn: the roll-outs' paths in their colour, where the empty viewer has none
            shot = _drawn(viewer, want=200)
        assert rollout_pixels(nothing) == 0
        assert np.mean(np.any(shot != nothing, axis=2)) > 0.25
