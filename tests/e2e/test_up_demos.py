"""`acnmp up --demos SKILL=FILE` as a new user runs it (issue 36): "deployment is up" only once the
model service serves SKILL (row 3: it was printed before, and a predict right after failed
``unknown_skill``); Ctrl-C then says what it stops before the deployment stops (row 10)."""
from __future__ import annotations

import signal
import uuid

from acnmp_core.demo_io import save_demos
from acnmp_core.tasks.viapoint import obstacle_demos
from clients.client import ACNMPClient
from services.learner.store import demo_set_to_arrays


def test_up_with_demos_is_up_once_the_skill_is_served_and_ctrl_c_says_what_it_stops(tmp_path, acnmp_up):
    demos = tmp_path / "mine.npz"
    save_demos(demos, demo_set_to_arrays(obstacle_demos(n_steps=30)))
    ns = f"demos-{uuid.uuid4().hex[:8]}"
    # enough steps that training outlasts the start of the other processes
    proc, lines = acnmp_up("--namespace", ns, "--workers", "0", "--demos", f"mine={demos}",
                           "--train-steps", "100", "--state-dir", str(tmp_path / "state"))
    try:
        assert any("waiting for the model service to serve skill 'mine'" in ln for ln in lines), lines
        with ACNMPClient(namespace=ns, role="client", timeout=10) as client:
            info = client.info("mine")  # at once: was unknown_skill for as long as the training took
        assert info["skill"] == "mine" and info["version"] == 0
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, out
    stopping = [ln for ln in out.splitlines() if ln.startswith("acnmp up: stopping")]
    assert len(stopping) == 1 and "learner" in stopping[0] and "model" in stopping[0], out
    assert "deployment stopped" in out.splitlines()[-1]
