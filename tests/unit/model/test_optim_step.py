"""FusedAdam and Stepper (acnmp_core/model/optim_step.py) update parameters exactly as torch.optim's
fused Adam and ``opt.step()`` would."""
from __future__ import annotations

import subprocess
import sys

import pytest
import torch

from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.optim_step import FusedAdam, Stepper, adam
from acnmp_core.model.training import TrainConfig, make_sampler, nll_loss


def _net(seed: int = 0) -> CNMP:
    return CNMP(CNMPConfig(n_outputs=2, encoder_widths=(32, 32), decoder_widths=(32, 32), prior="none"), seed=seed)


def _run(make_opt, e1_demos, *, stepper: bool, steps: int = 40, subset_from: int | None = None) -> tuple[CNMP, dict]:
    """``steps`` NLL steps on E1 episodes; from step ``subset_from`` on, the encoder's last layer
    gets no gradient on odd steps (its grad is dropped), so a parameter's grad comes and goes; at
    step 20 the learning rate of every group halves."""
    model = _net()
    model.fit_normalization(e1_demos)
    sampler = make_sampler(model, e1_demos, TrainConfig())
    gen = torch.Generator().manual_seed(3)
    opt = make_opt(model)
    step_fn = Stepper(opt) if stepper else None
    last = list(model.encoder[-1].parameters())
    for i in range(steps):
        loss = nll_loss(model, sampler.sample(16, gen), 0.5)
        (step_fn or opt).zero_grad()
        loss.backward()
        if subset_from is not None and i >= subset_from and i % 2:
            for p in last:
                p.grad = None
        if i == 20:
            for g in opt.param_groups:
                g["lr"] *= 0.5
        (step_fn or opt).step()
    return model, opt.state_dict()


def _same(a: tuple[CNMP, dict], b: tuple[CNMP, dict]) -> None:
    for (ka, va), (kb, vb) in zip(a[0].state_dict().items(), b[0].state_dict().items()):
        assert ka == kb and torch.equal(va, vb), ka
    sa, sb = a[1]["state"], b[1]["state"]
    assert sa.keys() == sb.keys()
    for k in sa:
        for name in sa[k]:
            assert torch.equal(sa[k][name], sb[k][name]), (k, name)


def test_stepper_matches_fused_adam_bit_for_bit(e1_demos):
    def adam(model):
        return torch.optim.Adam(model.parameters(), lr=1e-3, fused=True)

    _same(_run(adam, e1_demos, stepper=True), _run(adam, e1_demos, stepper=False))


def test_stepper_matches_when_grads_come_and_go_and_with_two_groups(e1_demos):
    def adam(model):
        return torch.optim.Adam([{"params": model.encoder.parameters()},
                                 {"params": model.decoder.parameters(), "lr": 3e-4}], lr=1e-3, fused=True)

    _same(_run(adam, e1_demos, stepper=True, subset_from=5), _run(adam, e1_demos, stepper=False, subset_from=5))


def test_stepper_takes_the_short_path_only_for_a_plain_fused_adam(e1_demos):
    for make in (lambda m: torch.optim.Adam(m.parameters(), lr=1e-3),  # foreach, not fused
                 lambda m: torch.optim.Adam(m.parameters(), lr=1e-3, fused=True, amsgrad=True),
                 lambda m: torch.optim.SGD(m.parameters(), lr=1e-2, momentum=0.9)):
        assert not Stepper(make(_net()))._short
        _same(_run(make, e1_demos, stepper=True, steps=25), _run(make, e1_demos, stepper=False, steps=25))
    assert Stepper(torch.optim.Adam(_net().parameters(), lr=1e-3, fused=True))._short


def test_stepper_runs_the_optimizers_hooks(e1_demos):
    model = _net()
    model.fit_normalization(e1_demos)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3, fused=True)
    calls = []
    opt.register_step_post_hook(lambda *_: calls.append(1))
    stepper = Stepper(opt)
    ep = make_sampler(model, e1_demos, TrainConfig()).sample(8, torch.Generator().manual_seed(0))
    for _ in range(3):
        stepper.zero_grad()
        nll_loss(model, ep).backward()
        stepper.step()
    assert len(calls) == 3


def test_fused_adam_is_torch_fused_adam_bit_for_bit(e1_demos):
    """Same weights and same state as torch.optim.Adam(fused=True), with two groups of their own
    rates, weight decay, a rate changed mid-run and grads that come and go."""
    def groups(model):
        return [{"params": model.encoder.parameters()}, {"params": model.decoder.parameters(), "lr": 3e-4}]

    ours = _run(lambda m: FusedAdam(groups(m), lr=1e-3, weight_decay=1e-4), e1_demos, stepper=True, subset_from=5)
    torch_adam = _run(lambda m: torch.optim.Adam(groups(m), lr=1e-3, weight_decay=1e-4, fused=True), e1_demos,
                      stepper=False, subset_from=5)
    _same(ours, torch_adam)
    assert ours[1]["param_groups"][1]["lr"] == torch_adam[1]["param_groups"][1]["lr"] == 1.5e-4
    _same(_run(lambda m: FusedAdam(m.parameters()), e1_demos, stepper=False),
          _run(lambda m: torch.optim.Adam(m.parameters(), fused=True), e1_demos, stepper=False))


def test_fused_adam_refuses_what_its_kernel_cannot_step():
    with pytest.raises(ValueError, match="floating-point"):
        FusedAdam([torch.zeros(3, dtype=torch.int64)])


def test_training_and_adaptation_leave_torch_dynamo_unimported():
    """torch.optim's constructor imports torch._dynamo (~1.9 s of CPU, at every learner's start and
    every experiment's first training); the library's own steps must not."""
    code = (
        "import sys\n"
        "from acnmp_core.experiments.viapoint import run_viapoint\n"
        "run_viapoint(seed=0, budget=3, train_steps=5, progress=False)\n"
        "assert 'torch._dynamo' not in sys.modules, 'torch._dynamo was imported'\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]


def test_the_default_adam_is_the_librarys_on_cpu_and_torchs_fused_elsewhere():
    assert isinstance(adam([torch.zeros(3, requires_grad=True)], lr=1e-3), FusedAdam)
    # parameters on another device (CUDA there; the meta device here) get torch's fused Adam
    elsewhere = adam([torch.zeros(3, device="meta", requires_grad=True)], lr=1e-3)
    assert type(elsewhere) is torch.optim.Adam and elsewhere.param_groups[0]["fused"]
