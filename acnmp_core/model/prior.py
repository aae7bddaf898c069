"""The linear-Gaussian path of a CNMP: the demonstrations' ProMP, jointly Gaussian with their task parameters.

Each demonstration (normalised units: phase ``t`` in [0, 1], outputs standardised, task parameters
mapped to [0, 1]) is summarised by the least-squares weights ``w`` (D*K,) of K normalised Gaussian
basis functions per output (a ProMP, Paraschos et al., NeurIPS 2013). The weights and the task
parameters ``c`` (P,) of the N demonstrations form one joint Gaussian ``z = [w, c]``, mean ``mu``
and covariance ``S`` (their sample statistics plus a small ridge). Conditioning it on task parameters
and on observed points ``y(t_i)`` is Gaussian conditioning (Paraschos et al. 2018, Eq. 8 and its
context extension):

    mu' = mu + S H^T (H S H^T + R)^-1 (y - H mu)

with ``H`` stacking the basis at the observed times (one row per observed output) and the identity on
the task parameters, ``R`` the demonstrations' fit residual per output (for the observations) and a
near-zero variance for the task parameters. The conditioned mean path ``Phi(t) w'`` is a linear
function of the task parameters and of the observed values: on demonstrations that vary linearly
with them (Meta-World's scripted paths, an amplitude times one shape) it extrapolates beyond their
range, which a network trained on a dozen of them does not.

:func:`choose_n_basis` picks K by leave-one-out error on the demonstrations alone: each is held
out in turn, the prior fitted to the others and conditioned on the held-out one's task parameters
and start (and, without task parameters, also its middle and end), and the path it predicts
compared with the held-out demonstration.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import torch
from torch import nn

#: basis counts :func:`choose_n_basis` tries by default
BASIS_CANDIDATES = (4, 6, 8, 10, 12, 15, 20)
#: added to the joint covariance's diagonal (normalised units squared): keeps it invertible with fewer
#: demonstrations than weights, and leaves conditioning room to move outside the demonstrations' span
COV_RIDGE = 1e-4
#: the variance given to task parameters when conditioning on them (normalised units): near-exact
PARAM_VARIANCE = 1e-6


class LinearPrior(nn.Module):
    """The demonstrations' joint Gaussian over basis weights and task parameters (module docstring).

    Parameters
    ----------
    n_outputs : D. n_task_params : P (0 allowed). n_basis : K >= 2 basis functions per output.

    Buffers (float64, normalised units; they travel in checkpoints): ``centers`` (K,), ``mu``
    (D*K+P,), ``cov`` (D*K+P, D*K+P), ``noise`` (D,) the fit residual variance per output;
    ``fitted`` (bool). The arithmetic is numpy's: its inputs are data (no gradient flows through the
    path), and on arrays this small a numpy call costs a fraction of a torch one.
    """

    def __init__(self, n_outputs: int, n_task_params: int, n_basis: int) -> None:
        super().__init__()
        if n_basis < 2:
            raise ValueError(f"n_basis: expected at least 2 basis functions, got {n_basis}")
        self.n_outputs, self.n_task_params, self.n_basis = int(n_outputs), int(n_task_params), int(n_basis)
        size = self.n_outputs * self.n_basis + self.n_task_params
        self.register_buffer("centers", torch.linspace(0.0, 1.0, self.n_basis, dtype=torch.float64))
        self.register_buffer("mu", torch.zeros(size, dtype=torch.float64))
        self.register_buffer("cov", torch.eye(size, dtype=torch.float64))
        self.register_buffer("noise", torch.ones(self.n_outputs, dtype=torch.float64))
        self.register_buffer("fitted", torch.zeros((), dtype=torch.bool))
        self._derived: tuple | None = None

    def basis(self, t: np.ndarray) -> np.ndarray:
        """(..., K) normalised RBF activations at phases ``t`` (...); each row sums to 1."""
        width = 1.0 / (self.n_basis - 1)
        logits = -0.5 * ((np.asarray(t, dtype=np.float64)[..., None] - self._centers) / width) ** 2
        act = np.exp(logits - logits.max(axis=-1, keepdims=True))
        return act / act.sum(axis=-1, keepdims=True)

    @property
    def _centers(self) -> np.ndarray:
        return self._numbers()[0]

    def _load_from_state_dict(self, *args, **kwargs):
        self._derived = None  # the buffers change: what is computed from them is computed again
        super()._load_from_state_dict(*args, **kwargs)

    def fit(self, times: np.ndarray, values: np.ndarray, task_params: np.ndarray,
            lengths: np.ndarray | None = None) -> "LinearPrior":
        """Fit on N demonstrations in normalised units: times (N, T), values (N, T, D), task
        parameters (N, P); ``lengths`` (N,) the valid rows of each (padding after them is ignored).
        Returns self."""
        times, values = np.asarray(times, dtype=np.float64), np.asarray(values, dtype=np.float64)
        n, t_max = times.shape
        valid = (np.ones((n, t_max), dtype=bool) if lengths is None
                 else np.arange(t_max)[None, :] < np.asarray(lengths)[:, None])
        phi = self.basis(times) * valid[..., None]  # (N, T, K), padded rows zero
        gram = phi.transpose(0, 2, 1) @ phi + 1e-6 * np.eye(self.n_basis)
        w = np.linalg.solve(gram, phi.transpose(0, 2, 1) @ (values * valid[..., None]))  # (N, K, D)
        resid = ((phi @ w - values) * valid[..., None]) ** 2
        z = np.concatenate([w.transpose(0, 2, 1).reshape(n, -1), np.asarray(task_params, dtype=np.float64).reshape(n, -1)],
                           axis=1)
        cov = np.cov(z.T).reshape(z.shape[1], z.shape[1]) if n > 1 else np.zeros((z.shape[1], z.shape[1]))
        self.noise.copy_(torch.from_numpy(resid.sum((0, 1)) / valid.sum() + 1e-6))
        self.mu.copy_(torch.from_numpy(z.mean(axis=0)))
        self.cov.copy_(torch.from_numpy(cov + COV_RIDGE * np.eye(z.shape[1])))
        self.fitted.fill_(True)
        self._derived = None
        return self

    def _numbers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """numpy copies of what conditioning uses, computed once after each fit or load: ``centers``
        (K,), ``mu_w`` (D*K,), ``mu_c`` (P,), the regression ``A`` (D*K, P) with ``E[w | c] = mu_w +
        A (c - mu_c)``, the weights' covariance given the parameters as (D, K, D, K), and ``noise``
        (D,)."""
        if self._derived is None:
            m = self.n_outputs * self.n_basis
            mu, cov = self.mu.numpy(), self.cov.numpy()
            s_wc, s_cc = cov[:m, m:], cov[m:, m:]
            a = (np.linalg.solve(s_cc + PARAM_VARIANCE * np.eye(self.n_task_params), s_wc.T).T
                 if self.n_task_params else np.zeros((m, 0)))
            given = cov[:m, :m] - a @ s_wc.T
            given = ((given + given.T) / 2).reshape(self.n_outputs, self.n_basis, self.n_outputs, self.n_basis)
            self._derived = (self.centers.numpy().copy(), mu[:m].copy(), mu[m:].copy(), a, given,
                             self.noise.numpy().copy())
        return self._derived

    def condition(self, obs_t: np.ndarray, obs_v: np.ndarray, obs_dims: np.ndarray, obs_mask: np.ndarray,
                  task_params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The conditioned mean weights (B, D, K) given B queries, and their path at the observation
        phases (B, N, D): observation phases (B, N), values (B, N, D), which outputs each observes
        (B, N, D, 0/1), which observations are real (B, N, bool; padding is not) and task parameters
        (B, P), all normalised. The model (the CNMP) uses the weights; the path at the observations
        is for whoever checks what the conditioning did.

        Conditioned first on the task parameters (a linear regression, :meth:`_numbers`), then
        on the observations: ``w' = w_c + S H^T (H S H^T + R)^-1 (y - H w_c)`` with ``S`` the
        weights' covariance given the parameters; an unobserved entry has no innovation and
        unit variance, so it changes nothing."""
        b, n = np.shape(obs_t)
        d, k = self.n_outputs, self.n_basis
        _, mu_w, mu_c, a, cov, noise = self._numbers()
        w = (mu_w + (np.asarray(task_params, dtype=np.float64).reshape(b, -1) - mu_c) @ a.T).reshape(b, d, k)
        phi = self.basis(obs_t)  # (B, N, K)
        if n == 0:  # the task parameters alone
            return w, np.zeros((b, 0, d))
        seen = np.asarray(obs_dims, dtype=np.float64) * np.asarray(obs_mask, dtype=np.float64)[..., None]  # (B, N, D)
        innovation = (np.asarray(obs_v, dtype=np.float64) - np.einsum("bnk,bdk->bnd", phi, w)) * seen
        # rows (n, e) of H S: the basis at t_n read through output e's block of S, masked
        hs = np.einsum("bnk,ekfl->bnefl", phi, cov) * seen[..., None, None]
        gram = np.einsum("bnefl,bml->bnemf", hs, phi) * seen[:, None, None, :, :]
        gram = gram.reshape(b, n * d, n * d)
        diag = (noise * seen + (1.0 - seen)).reshape(b, n * d)
        idx = np.arange(n * d)
        gram[:, idx, idx] += diag
        sol = np.linalg.solve(gram, innovation.reshape(b, n * d, 1)).reshape(b, n, d)
        w = w + np.einsum("bnefl,bne->bfl", hs, sol)
        return w, np.einsum("bnk,bdk->bnd", phi, w)

    def path(self, t: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """(B, M, D) the mean path of ``weights`` (B, D, K) at phases ``t`` (B, M)."""
        return np.einsum("bmk,bdk->bmd", self.basis(t), weights)


def condition_marks(n_steps: int, n_task_params: int) -> list[int]:
    """The rows of a held-out demonstration a leave-one-out prediction is conditioned on, besides
    its task parameters: its start, and without task parameters also its middle and end."""
    return [0] if n_task_params else [0, n_steps // 2, n_steps - 1]


#: an output whose standard deviation over the demonstrations is below this fraction of its largest
#: magnitude (plus this, absolutely) is constant: it carries nothing to hold out
CONSTANT_OUTPUT = 1e-9


def varying_outputs(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The outputs of demonstrations ``values`` (N, T, D) that vary (a bool mask (D,)) and their
    standard deviations (D,). A constant output (a gripper held closed) has a spread of rounding
    noise: dividing by it would turn the noise into errors of any size."""
    flat = values.reshape(-1, values.shape[-1])
    std = flat.std(axis=0)
    return std > CONSTANT_OUTPUT * (1.0 + np.abs(flat).max(axis=0)), std


def leave_one_out(values: np.ndarray, task_params: np.ndarray,
                  predict: Callable[[list[int], int, list[int]], np.ndarray],
                  held_out: Sequence[int] | None = None) -> float:
    """Mean over the held-out demonstrations (default all N; values (N, T, D), task parameters
    (N, P)) of the RMS error of ``predict(rest, k, marks)`` -- a model of demonstrations ``rest``
    conditioned on demonstration ``k``'s task parameters and its rows ``marks``
    (:func:`condition_marks`), (T, D) -- against demonstration ``k``, in units of each output's
    standard deviation over the demonstrations. Outputs that do not vary (:func:`varying_outputs`)
    are left out; with none varying the error is 0."""
    n, t_len, _ = values.shape
    varying, std = varying_outputs(values)
    if not varying.any():
        return 0.0
    marks = condition_marks(t_len, task_params.shape[1])
    ks = range(n) if held_out is None else held_out
    errs = [np.sqrt(np.mean((((predict([i for i in range(n) if i != k], k, marks) - values[k]) / np.where(varying, std, 1.0))
                             [:, varying]) ** 2))
            for k in ks]
    return float(np.mean(errs))


def _loo_error(times: np.ndarray, values: np.ndarray, task_params: np.ndarray, n_basis: int) -> float:
    """:func:`leave_one_out` of the linear path with ``n_basis`` basis functions."""
    d, p = values.shape[2], task_params.shape[1]

    def predict(rest: list[int], k: int, marks: list[int]) -> np.ndarray:
        prior = LinearPrior(d, p, n_basis).fit(times[rest], values[rest], task_params[rest])
        w, _ = prior.condition(times[k][marks][None], values[k][marks][None], np.ones((1, len(marks), d)),
                               np.ones((1, len(marks)), dtype=bool), task_params[k][None])
        return prior.path(times[k][None], w)[0]

    return leave_one_out(values, task_params, predict)


def choose_n_basis(times: np.ndarray, values: np.ndarray, task_params: np.ndarray,
                   candidates: Sequence[int] = BASIS_CANDIDATES) -> tuple[int, dict[int, float]]:
    """The basis count with the lowest leave-one-out error (:func:`leave_one_out`) of the linear path
    on the demonstrations (module docstring) and every candidate's error: times (N, T) phase, values (N, T, D), task parameters (N, P), all
    normalised, on one time grid. With fewer than 3 demonstrations there is nothing to hold out:
    the smallest candidate. Ties go to the fewer basis functions."""
    times, values = np.asarray(times, dtype=np.float64), np.asarray(values, dtype=np.float64)
    task_params = np.asarray(task_params, dtype=np.float64).reshape(len(values), -1)
    cands = sorted(int(c) for c in candidates)
    if len(values) < 3:
        return cands[0], {}
    errors = {c: _loo_error(times, values, task_params, c) for c in cands}
    best = min(cands, key=lambda c: (round(errors[c], 12), c))
    return best, errors
