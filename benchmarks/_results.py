"""Writing an experiment benchmark's result: JSON and its figure beside it, and a short summary."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Callable


def save_result(result: dict, out: str | Path, plot: Callable[[dict, Path], object], ratio_key: str) -> None:
    """Write ``result`` to ``out`` (JSON), its figure to ``out`` with a .png suffix via ``plot``,
    and print the per-method summary with ``result[ratio_key]`` and the wall time."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2))
    plot(result, out.with_suffix(".png"))
    print(json.dumps({"methods": result["methods"], "ratio": result[ratio_key],
                      "wall_time_s": result["wall_time_s"]}, indent=1))
    print(f"wrote {out} and {out.with_suffix('.png')}")
