"""The optimiser half of a gradient step, without torch.optim's per-step Python bookkeeping.

The CNMPs are small: a supervised step costs a few milliseconds, and ``torch.optim.Adam.step``
spends about as long in Python (profiler scopes, hooks, rebuilding its lists of parameters, grads
and states, grouping them by device) as its fused kernel takes to update every weight. Once a
fused Adam has made one ordinary step (which creates its state), :class:`Stepper` calls the same
two kernels ``Adam.step`` ends in (``torch._foreach_add_`` on the step counters, then
``torch._fused_adam_``) with the same arguments on the same tensors, so the result is bit for bit
that of ``opt.step()`` (tests/unit/model/test_optim_step.py compares them). Anything it does not
recognise (another optimiser, a non-fused Adam, amsgrad, a tensor learning rate, hooks, a
parameter whose grad appears or disappears) goes through ``opt.step()`` itself.
"""
from __future__ import annotations

import torch
from torch.optim.optimizer import _global_optimizer_post_hooks, _global_optimizer_pre_hooks


def _plain_fused_adam(opt: torch.optim.Optimizer) -> bool:
    """True when ``opt`` is a fused Adam whose step is exactly step counters + ``_fused_adam_``."""
    if type(opt) is not torch.optim.Adam:
        return False
    for g in opt.param_groups:
        if not (g.get("fused") and not g.get("amsgrad") and not g.get("maximize") and not g.get("capturable")
                and not g.get("differentiable") and not g.get("decoupled_weight_decay")
                and isinstance(g["lr"], float) and all(isinstance(b, float) for b in g["betas"])):
            return False
    params = [p for g in opt.param_groups for p in g["params"]]
    return len({(p.device, p.dtype) for p in params}) == 1 and params[0].device.type == "cpu"


class Stepper:
    """``zero_grad()`` and ``step()`` of one optimiser, for a training loop that calls them each step.

    opt : any ``torch.optim.Optimizer``; a fused ``torch.optim.Adam`` takes the short path (see the
    module docstring), every other optimiser is stepped by its own ``step()``. The optimiser's
    state stays its own, so it can be saved or handed on as usual.
    """

    def __init__(self, opt: torch.optim.Optimizer) -> None:
        self.opt = opt
        self._params = [p for g in opt.param_groups for p in g["params"]]
        self._short = _plain_fused_adam(opt)
        #: per param group: (group, params, exp_avgs, exp_avg_sqs, step counters), from the last
        #: ordinary step; None until then
        self._groups: list[tuple[dict, list, list, list, list]] | None = None
        self._key: tuple[int, ...] = ()

    def zero_grad(self) -> None:
        """Drop every parameter's gradient (``opt.zero_grad(set_to_none=True)``)."""
        for p in self._params:
            p.grad = None

    def _with_grads(self) -> tuple[int, ...]:
        return tuple(i for i, p in enumerate(self._params) if p.grad is not None)

    def step(self) -> None:
        """Update the parameters from their gradients, exactly as ``opt.step()``."""
        if not self._short or (self.opt._optimizer_step_pre_hooks or self.opt._optimizer_step_post_hooks
                               or _global_optimizer_pre_hooks or _global_optimizer_post_hooks):
            self.opt.step()
            return
        key = self._with_grads()
        if self._groups is None or key != self._key:
            self.opt.step()  # creates the state of parameters that have a gradient for the first time
            self._remember(key)
            return
        with torch.no_grad():
            for g, params, exp_avgs, exp_avg_sqs, steps in self._groups:
                beta1, beta2 = g["betas"]
                torch._foreach_add_(steps, 1)
                torch._fused_adam_(params, [p.grad for p in params], exp_avgs, exp_avg_sqs, [], steps,
                                   amsgrad=False, lr=g["lr"], beta1=beta1, beta2=beta2,
                                   weight_decay=g["weight_decay"], eps=g["eps"], maximize=False,
                                   grad_scale=None, found_inf=None)

    def _remember(self, key: tuple[int, ...]) -> None:
        """Cache, per group, the parameters that have a gradient and their state tensors."""
        groups = []
        for g in self.opt.param_groups:
            params = [p for p in g["params"] if p.grad is not None]
            if params:
                states = [self.opt.state[p] for p in params]
                groups.append((g, params, [s["exp_avg"] for s in states], [s["exp_avg_sq"] for s in states],
                               [s["step"] for s in states]))
        self._groups, self._key = groups, key
