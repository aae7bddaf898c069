"""Drawing the experiments' figures headless: matplotlib on its Agg backend, imported on first use
(it takes about a second to import, and only the figures need it)."""
from __future__ import annotations


def pyplot():
    """``matplotlib.pyplot`` on the headless Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path, dpi: int = 110):
    """Lay ``fig`` out, write it to ``path`` (PNG, ``dpi`` dots per inch) and close it; returns ``path``."""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    return path
