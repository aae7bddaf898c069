"""``acnmp reproduce --quick --only E1`` end to end: the experiment runs as its own command, the
report (markdown and a self-contained HTML page) holds its table, target, time and figure, and a
second run keeps the finished experiment instead of running it again."""
from __future__ import annotations

import json

from clients.cli import main


def test_reproduce_quick_e1_writes_the_report_and_resumes(tmp_path, capsys):
    out = tmp_path / "paper"
    assert main(["reproduce", "-o", str(out), "--quick", "--only", "E1"]) == 0
    result = json.loads((out / "E1.json").read_text())
    md = (out / "report.md").read_text()
    assert md.startswith("# ACNMP: the paper reproduced (quick sizes)")
    shape = result["methods"]["acnmp"]["shape_error"]
    assert f"ACNMP shape error <= 0.05 m: {shape:.3f} m" in md and ("PASS" if shape <= 0.05 else "FAIL") in md
    assert "lfd_only" in md and "![E1](E1.png)" in md  # the command's own table and its figure
    page = (out / "report.html").read_text()
    assert "data:image/png;base64," in page and "<h2>E2" not in page
    assert json.loads((out / "E1.meta.json").read_text())["quick"] is True
    capsys.readouterr()
    assert main(["reproduce", "-o", str(out), "--quick", "--only", "e1"]) == 0  # resumes: nothing to run
    assert "E1: kept" in capsys.readouterr().out


def test_only_names_the_experiments(tmp_path, capsys):
    assert main(["reproduce", "-o", str(tmp_path), "--only", "E7"]) == 2
    assert "--only 'E7': expected some of E1, E2, E3, E4, E5, E6" in capsys.readouterr().err
