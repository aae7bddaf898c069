"""The figure of the peers comparison: per task and case, the share of seeds succeeded against episodes."""
from __future__ import annotations

from pathlib import Path

from .config import METHODS, PeerRun

#: colours and labels of the methods
STYLE = {"lfd": ("tab:pink", "LfD only"), "lfd_paper": ("tab:red", "LfD only (paper's CNMP)"),
         "lfd_linear": ("lightpink", "LfD only (previous default)"),
         "acnmp": ("tab:green", "ACNMP"), "acnmp_paper": ("darkgreen", "ACNMP (paper's method)"),
         "acnmp_linear": ("yellowgreen", "ACNMP (previous default)"),
         "promp_rl": ("tab:blue", "ProMP + RL"), "promp_cma": ("tab:purple", "ProMP + CMA-ES"),
         "promp_cma5": ("violet", "ProMP + CMA-ES (5 bases)"),
         "promp_rl_dense": ("tab:cyan", "ProMP + RL, dense reward"),
         "promp_cma_dense": ("indigo", "ProMP + CMA-ES, dense reward"),
         "promp_cma5_dense": ("plum", "ProMP + CMA-ES (5 bases), dense reward"), "ppo": ("tab:orange", "PPO"),
         "ppo_bc": ("tab:brown", "PPO + BC"), "sac_bc": ("tab:olive", "SAC + BC"), "sac": ("tab:gray", "SAC")}
#: panels per row
COLUMNS = 4


def plot_peers(result: dict, path) -> Path:
    """Write the figure: one panel per task and case, the fraction of seeds whose method has
    succeeded against the episodes executed (log scale), one step line per method; censored runs
    never rise. Returns the path."""
    from ..figures import pyplot

    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    runs = [PeerRun.from_json(r) for r in result["runs"]]
    panels = [(t, c) for t in result["config"]["tasks"] for c in result["config"]["cases"]
              if any((r.task, r.case) == (t, c) for r in runs)]
    rows = max(1, -(-len(panels) // COLUMNS))
    fig, axes = plt.subplots(rows, COLUMNS, figsize=(4.0 * COLUMNS, 3.0 * rows), squeeze=False)
    top = max([r.budget for r in runs] + [10])
    for ax, (task, case) in zip(axes.flat, panels):
        for method in result["config"]["methods"]:
            rs = [r for r in runs if (r.task, r.case, r.method) == (task, case, method)]
            if not rs:
                continue
            color, label = STYLE[method]
            done = sorted(r.episodes for r in rs if r.success)
            xs = [1.0] + [float(e) for e in done] + [float(top)]
            # methods that coincide (all succeeding at once) are told apart by a small offset
            lift = 0.012 * (METHODS.index(method) - len(METHODS) / 2)
            ys = [lift] + [(i + 1) / len(rs) + lift for i in range(len(done))] + [len(done) / len(rs) + lift]
            ax.step(xs, ys, where="post", color=color, lw=1.6, label=label)
        ax.set_xscale("log")
        ax.set_ylim(-0.08, 1.08)
        ax.set_title(f"{task.removeprefix('metaworld-')}, {case}", fontsize=10)
        ax.set_ylabel("share of seeds succeeded", fontsize=8)
        ax.set_xlabel("episodes executed (log)", fontsize=8)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=min(6, len(handles)), fontsize=8)
    fig.suptitle("Share of seeds succeeded against episodes executed, per task and case", fontsize=11)
    fig.tight_layout(rect=(0, 0.03 + 0.025 * ((len(handles) + 5) // 6), 1, 0.97))
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
