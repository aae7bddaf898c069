"""Figures of the experiments (matplotlib, headless Agg backend): every figure the project draws."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import push as push_exp  # noqa: E402
from .figures import save_figure  # noqa: E402
from . import wall as wall_exp  # noqa: E402

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
    save_figure(fig, path)

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
    save_figure(fig, lat_path)
    return [path, lat_path]


def plot_push(result: dict, path) -> "object":
    """Write learning curves like the paper's Fig. 5(b): final-position error of the mean trajectory
    vs roll-outs, median and inter-quartile band over seeds, per method, one panel per case.
    Returns the written path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    colors, labels = wall_exp.COLORS, wall_exp.LABELS
    cases = [c for c in push_exp.CASES if any(r["case"] == c for r in result["runs"])]
    fig, axes = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 4.2), squeeze=False)
    for ax, case in zip(axes[0], cases):
        runs = [r for r in result["runs"] if r["case"] == case]
        top = max(r["curve"][-1][0] for r in runs)
        grid = np.arange(1, top + 1)
        for m in push_exp.METHODS:
            curves = [r["curve"] for r in runs if r["method"] == m]
            if not curves:
                continue
            med, lo, hi = push_exp.curve_band(curves, grid)
            s = result["methods"][m][case]
            ax.plot(grid, med, color=colors[m],
                    label=f"{labels[m]}: median {s['rollouts_median']:.0f} roll-outs, "
                          f"success {100 * s['success_rate']:.0f} %")
            ax.fill_between(grid, lo, hi, color=colors[m], alpha=0.25)
        ax.axhline(result["tolerance"], color="k", ls="--", lw=1, label=f"tolerance {result['tolerance']} m")
        ax.set_xscale("log")
        ax.set_xlim(left=1)
        ax.set_xlabel("roll-outs")
        ax.set_ylabel("object's final distance to target (m)")
        ax.set_title(f"E2 push, {case} ({result['seeds']} seeds)")
        ax.legend(fontsize=8)
    return save_figure(fig, path)


def plot_wall(result: dict, path) -> "object":
    """Write the paper's Fig. 5 d, e: test error and success rate against environments seen (left)
    and against trajectories sampled (right), one line per method. Returns the written path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey="row")
    for m, curve in result["curves"].items():
        envs = [p["envs_seen"] for p in curve]
        traj = [p["trajectories"] for p in curve]
        s = result["methods"][m]
        label = f"{wall_exp.LABELS[m]}: {s['trajectories_total']} trajectories, max {s['trajectories_per_env_max']}/env"
        for col, x in enumerate((envs, traj)):
            axes[0, col].plot(x, [p["test_error_mean"] for p in curve], color=wall_exp.COLORS[m], label=label)
            axes[1, col].plot(x, [100 * p["test_success_rate"] for p in curve], color=wall_exp.COLORS[m], label=label)
    for row, ylab in enumerate(("mean test error (world units)", "test success (%)")):
        axes[row, 0].set_ylabel(ylab)
        axes[row, 0].set_xlabel("environments seen")
        axes[row, 1].set_xlabel("trajectories sampled")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"E3 wall: {result['n_initial']} demonstrated + {result['envs']} new environments, "
                 f"{result['n_test']} test environments (seed {result['seed']})")
    return save_figure(fig, path)


def plot_transfer(result: dict, path) -> "object":
    """Write E4's figure: share of runs whose mean roll-out succeeded within k RL iterations, per
    condition (transfer and both controls), with the paper's 23/73/90/100 % at 3/7/11/19 beside.
    Returns the written path."""
    from . import transfer as transfer_exp

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    styles = {"transfer": ("tab:green", "transfer (A's encoder -> B's decoder)"),
              "no_alignment": ("tab:orange", "control: no latent alignment"),
              "no_transfer": ("tab:red", "control: B's own LfD model")}
    runs = result["per_run"]
    top = max(r["curve"][-1][0] for r in runs)  # the iterations run, not more
    ks = np.arange(0, top + 1)
    for cond, (color, label) in styles.items():
        its = [r["iterations"] for r in runs if r["condition"] == cond]
        if not its:
            continue
        share = [np.mean([i is not None and i <= k for i in its]) for k in ks]
        # The controls often coincide: the dashed one is drawn on top so both stay visible.
        dashed = cond == "no_alignment"
        ax.step(ks, 100 * np.asarray(share), where="post", color=color, lw=2, label=label,
                ls="--" if dashed else "-", zorder=3 if dashed else 2)
    paper = {k: v for k, v in result["paper"]["success_by_iteration"].items() if int(k) <= top}
    ax.plot([int(k) for k in paper], [100 * v for v in paper.values()], "ks", ms=7, mfc="none",
            label="paper (Akbulut et al. 2020)")
    ax.set_xlabel("RL iterations (2 roll-outs each)")
    ax.set_ylabel("runs succeeded (%)")
    ax.set_ylim(-3, 103)
    ax.set_title(f"E4: 3-DoF -> 4-DoF transfer, cube through the gap ({result['runs']} runs)")
    ax.legend(fontsize=8, loc="lower right")
    return save_figure(fig, path)
