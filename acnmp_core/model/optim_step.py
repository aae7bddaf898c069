"""The optimiser half of a gradient step: Adam on torch's fused kernel, without torch.optim's overhead.

:class:`FusedAdam` is Adam (Kingma & Ba, 2015, Algorithm 1) with the state and the numbers of
``torch.optim.Adam(params, lr, fused=True)`` on CPU, bit for bit (tests/unit/model/test_optim_step.py),
stepped by the two kernels that optimiser ends in (``torch._foreach_add_`` on the step counters,
then ``torch._fused_adam_``). It exists for two costs of torch.optim: its constructor imports
torch._dynamo (about 1.9 s of CPU in every process that trains), and its ``step`` spends about as
long in Python (profiler scopes, hooks, lists rebuilt each step) as the kernel takes on these small
networks.

:func:`adam` is the library's default: a :class:`FusedAdam` over CPU parameters, torch's own
fused Adam over parameters on another device.

:class:`Stepper` drives any optimiser a caller hands in (``zero_grad`` and ``step``): a
:class:`FusedAdam` directly, a fused ``torch.optim.Adam`` on the same short path once its first
ordinary step has made its state, anything else (another optimiser, amsgrad, hooks, ...) through
its own ``step()``.
"""
from __future__ import annotations

import torch
from torch.optim.optimizer import _global_optimizer_post_hooks, _global_optimizer_pre_hooks


class FusedAdam:
    """Adam over CPU parameters, as ``torch.optim.Adam(params, lr=lr, betas=betas, eps=eps,
    weight_decay=weight_decay, fused=True)``: same state (``state[p]`` holds ``step``, a float32
    scalar tensor, ``exp_avg`` and ``exp_avg_sq``, shaped as ``p``), same updates bit for bit.

    params : the parameters (an iterable of tensors), or parameter groups (dicts with ``"params"``
        and any of the hyper-parameters below, which they override).
    lr : step size (a float; :func:`~acnmp_core.model.training.set_lr` changes it between steps).
    betas, eps, weight_decay : Adam's moment decays, denominator term and L2 penalty.
    """

    def __init__(self, params, lr: float = 1e-3, betas: tuple[float, float] = (0.9, 0.999), eps: float = 1e-8,
                 weight_decay: float = 0.0) -> None:
        defaults = {"lr": float(lr), "betas": (float(betas[0]), float(betas[1])), "eps": float(eps),
                    "weight_decay": float(weight_decay)}
        params = list(params)
        groups = params if params and isinstance(params[0], dict) else [{"params": params}]
        self.param_groups: list[dict] = [{**defaults, **g, "params": list(g["params"])} for g in groups]
        for g in self.param_groups:
            for p in g["params"]:
                if p.device.type != "cpu" or not p.is_floating_point():
                    raise ValueError(f"FusedAdam: CPU floating-point parameters only, got {p.dtype} on {p.device}")
        self.state: dict[torch.Tensor, dict[str, torch.Tensor]] = {}
        #: per group, its parameters with a gradient at the last step and their state tensors
        self._cache: list[tuple[tuple[int, ...], list, list, list, list]] = [((), [], [], [], []) for _ in groups]

    def zero_grad(self) -> None:
        """Drop every parameter's gradient (``set_to_none``)."""
        for g in self.param_groups:
            for p in g["params"]:
                p.grad = None

    def _group_tensors(self, i: int, g: dict) -> tuple[list, list, list, list]:
        """Group ``i``'s parameters that have a gradient, with their exp_avg, exp_avg_sq and step
        tensors (created at a parameter's first gradient, as torch.optim.Adam does)."""
        key = tuple(j for j, p in enumerate(g["params"]) if p.grad is not None)
        if key != self._cache[i][0]:
            params = [g["params"][j] for j in key]
            for p in params:
                if p not in self.state:
                    self.state[p] = {"step": torch.zeros((), dtype=torch.float32),
                                     "exp_avg": torch.zeros_like(p, memory_format=torch.preserve_format),
                                     "exp_avg_sq": torch.zeros_like(p, memory_format=torch.preserve_format)}
            states = [self.state[p] for p in params]
            self._cache[i] = (key, params, [s["exp_avg"] for s in states], [s["exp_avg_sq"] for s in states],
                              [s["step"] for s in states])
        return self._cache[i][1:]

    def step(self) -> None:
        """Update every parameter that has a gradient (Adam's step, Algorithm 1)."""
        with torch.no_grad():
            for i, g in enumerate(self.param_groups):
                params, exp_avgs, exp_avg_sqs, steps = self._group_tensors(i, g)
                if not params:
                    continue
                beta1, beta2 = g["betas"]
                torch._foreach_add_(steps, 1)
                torch._fused_adam_(params, [p.grad for p in params], exp_avgs, exp_avg_sqs, [], steps,
                                   amsgrad=False, lr=float(g["lr"]), beta1=beta1, beta2=beta2,
                                   weight_decay=g["weight_decay"], eps=g["eps"], maximize=False,
                                   grad_scale=None, found_inf=None)

    def state_dict(self) -> dict:
        """The state in torch.optim's layout: ``{"state": {index: {...}}, "param_groups": [...]}``,
        parameters numbered in group order."""
        index, groups = {}, []
        for g in self.param_groups:
            ids = [index.setdefault(p, len(index)) for p in g["params"]]
            groups.append({**{k: v for k, v in g.items() if k != "params"}, "params": ids})
        return {"state": {index[p]: dict(s) for p, s in self.state.items()}, "param_groups": groups}


def adam(params, lr: float) -> FusedAdam | torch.optim.Adam:
    """A fused Adam at rate ``lr`` over ``params`` (an iterable of tensors): a :class:`FusedAdam`
    when every parameter is a floating-point CPU tensor, else ``torch.optim.Adam(fused=True)``
    (a model trained on another device), whose numbers are the same."""
    params = list(params)
    if all(p.device.type == "cpu" and p.is_floating_point() for p in params):
        return FusedAdam(params, lr=lr)
    return torch.optim.Adam(params, lr=lr, fused=True)


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

    opt : a :class:`FusedAdam` or any ``torch.optim.Optimizer``; a fused ``torch.optim.Adam`` takes
    the short path (see the module docstring), every other optimiser is stepped by its own ``step()``. The optimiser's
    state stays its own, so it can be saved or handed on as usual.
    """

    def __init__(self, opt: torch.optim.Optimizer | FusedAdam) -> None:
        self.opt = opt
        self._params = [p for g in opt.param_groups for p in g["params"]]
        self._own = isinstance(opt, FusedAdam)
        self._short = self._own or _plain_fused_adam(opt)
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
        if self._own:
            self.opt.step()
            return
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
