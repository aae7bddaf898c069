"""Figures of the experiments (matplotlib, headless Agg backend)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

COLORS = {"lfd_only": "tab:blue", "rl_only": "tab:red", "acnmp": "tab:green"}
LABELS = {"lfd_only": "LfD only", "rl_only": "RL only", "acnmp": "ACNMP"}


def pca_2d(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean (L,), components (2, L), projected (N, 2)) of rows x (N, L)."""
    mean = x.mean(axis=0)
    _, _, vt = np.linalg.svd(x - mean, full_matrices=False)
    comps = vt[:2]
    if comps.shape[0] < 2:
        comps = np.vstack([comps, np.zeros_like(comps)])
    return mean, comps, (x - mean) @ comps.T


def plot_viapoint(run, path: str | Path) -> list[Path]:
    """Write the E1 figures: ``path`` like the paper's Fig. 3 (demos, LfD, RL-only, ACNMP and the
    conditions) and ``<stem>_latents.png`` like Fig. 4 (demo latents before and after assimilation,
    projected on the first two principal components of the 'before' set). Returns both paths."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    d = run.demos.n_outputs
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    ax = axes[0]
    cond_t, cond_v = run.conditions
    for i, demo in enumerate(run.demos):
        x, y = (demo.values[:, 0], demo.values[:, 1]) if d == 2 else (demo.times, demo.values[:, 0])
        ax.plot(x, y, color="0.7", lw=1, label="demonstrations" if i == 0 else None)
    for m, traj in run.trajectories.items():
        x, y = (traj[:, 0], traj[:, 1]) if d == 2 else (run.times, traj[:, 0])
        s = run.summary["methods"][m]
        ax.plot(x, y, color=COLORS[m], lw=2, label=f"{LABELS[m]} ({s['rollouts']} roll-outs, err {s['error']:.3f})")
    cx, cy = (cond_v[:, 0], cond_v[:, 1]) if d == 2 else (cond_t, cond_v[:, 0])
    via = run.via_index
    ax.plot([cx[via]], [cy[via]], "m*", ms=14, label="extrapolated via-point")
    others = [i for i in range(len(cx)) if i != via]
    ax.plot(cx[others], cy[others], "ks", ms=6, mfc="none", label="start and end (conditioned)")
    ax.set_xlabel("x" if d == 2 else "t")
    ax.set_ylabel("y")
    ax.set_title("E1: extrapolated via-point")
    ax.legend(fontsize=8, loc="lower left")
    ax = axes[1]
    for m, curve in run.curves.items():
        if curve:
            r, e = zip(*curve)
            ax.plot(r, e, "-o", ms=3, color=COLORS[m], label=LABELS[m])
    tol = np.ravel(run.summary["tolerance"])
    ax.axhline(tol[min(run.via_index, tol.size - 1)], color="k", ls="--", lw=1, label="via-point tolerance")
    ax.set_xlabel("roll-outs")
    ax.set_ylabel("error of the mean (largest distance to a condition)")
    ax.set_yscale("log")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

    lat_path = path.with_name(path.stem + "_latents.png")
    mean, comps, before = pca_2d(run.latents_before)
    after = (run.latents_after - mean) @ comps.T
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    ax.scatter(before[:, 0], before[:, 1], c="tab:blue", label="demos, before assimilation")
    n = len(before)
    ax.scatter(after[:n, 0], after[:n, 1], c="tab:orange", marker="x", label="demos, after")
    if len(after) > n:
        ax.scatter(after[n:, 0], after[n:, 1], c="tab:green", marker="*", s=150, label="assimilated ACNMP solution")
    ax.set_xlabel("latent PC 1")
    ax.set_ylabel("latent PC 2")
    ax.set_title("E1: latent representations (Fig. 4)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(lat_path, dpi=110)
    plt.close(fig)
    return [path, lat_path]
