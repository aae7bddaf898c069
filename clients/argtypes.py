"""Argparse types shared by the ``acnmp`` commands: bad values end in argparse's one-line error."""
from __future__ import annotations

import argparse


def int_at_least(lo: int):
    """An argparse type: an int >= ``lo`` (argparse names the option in its error)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text!r}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {value}")
        return value
    return parse
