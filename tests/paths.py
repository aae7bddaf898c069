"""Where the repository is, for the tests that read its files or run its scripts."""
from __future__ import annotations

from pathlib import Path

#: the repository's root (the folder holding pyproject.toml)
ROOT = Path(__file__).resolve().parents[1]
