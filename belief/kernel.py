"""The Matern-5/2 kernel of belief.surrogate's Gaussian process, and its fast cross-covariance.

k(r) = s^2 (1 + sqrt5 r + 5 r^2 / 3) exp(-sqrt5 r),  r = ||(x - x') / l||  (one lengthscale l_i per
input dimension). :class:`Matern52` is pyro's kernel with an autograd-free path for K(X, X);
:func:`augment` and :func:`matern52_unit` give the large query x data cross-covariance with one
matrix product and in-place ops on reused buffers.
"""
from __future__ import annotations

import pyro.contrib.gp as gp
import torch

__all__ = ["Matern52", "augment", "matern52_unit"]


class Matern52(gp.kernels.Matern52):
    """pyro's Matern-5/2 kernel; without autograd (K(X, X) when the surrogate predicts) the
    covariance is computed with ``torch.cdist`` and in-place ops, same values to ~1e-12. The large
    query x data cross-covariance of a prediction uses :func:`matern52_unit` instead."""

    def forward(self, X: torch.Tensor, Z: torch.Tensor | None = None, diag: bool = False) -> torch.Tensor:
        if diag or torch.is_grad_enabled():
            return super().forward(X, Z, diag)
        Z = X if Z is None else Z
        ls = self.lengthscale
        s5r = torch.cdist(self._slice_input(X) / ls, self._slice_input(Z) / ls,
                          compute_mode="donot_use_mm_for_euclid_dist").mul_(5.0**0.5)
        # pyro annotates the kernel's variance as its PyroParam declaration; read, it is a Tensor
        return (s5r.square() / 3.0 + s5r + 1.0).mul_(torch.exp(-s5r)).mul_(self.variance)  # type: ignore[arg-type]


def augment(u: torch.Tensor, query: bool) -> torch.Tensor:
    """Rows of ``u`` (``m x d``) extended so that one matrix product gives squared distances:
    [u, |u|^2, 1] (query) times [-2 x, 1, |x|^2]^T (data) = |u|^2 + |x|^2 - 2 u.x = |u - x|^2."""
    sq = (u * u).sum(1, keepdim=True)
    one = torch.ones_like(sq)
    return torch.cat([u, sq, one], 1) if query else torch.cat([-2.0 * u, one, sq], 1)


def matern52_unit(q_aug: torch.Tensor, x_aug_t: torch.Tensor, d2: torch.Tensor, s: torch.Tensor,
                   e: torch.Tensor) -> torch.Tensor:
    """Unit-variance Matern-5/2 cross-covariance ``k x n`` between augmented query rows ``q_aug``
    (``k x (d+2)``) and data ``x_aug_t`` (``(d+2) x n``), both pre-scaled by sqrt5 / lengthscale, so
    that d2 = 5 r^2 and k = (1 + sqrt(d2) + d2 / 3) exp(-sqrt(d2)). ``d2``, ``s``, ``e`` are ``k x n``
    work buffers (reused across chunks: no allocation); the result is written into ``s``.
    The expansion is clamped at 0; its rounding near r = 0 changes k by ~1e-16 (k is smooth in d2)."""
    torch.mm(q_aug, x_aug_t, out=d2)
    d2.clamp_(min=0.0)
    torch.sqrt(d2, out=s).neg_()                       # -sqrt5 r
    torch.exp(s, out=e)                                # exp(-sqrt5 r)
    torch.add(s, d2, alpha=-1.0 / 3.0, out=d2)         # -(sqrt5 r + 5 r^2 / 3)
    return torch.addcmul(e, d2, e, value=-1.0, out=s)  # e (1 + sqrt5 r + 5 r^2 / 3)
