"""Curiosity: S-ICM (the paper's forward model, Eq. 4, 7-8) and ICM
(Pathak et al. 2017, a baseline).

Both are trained on the same minibatch and in the same step as the policy (Eq. 7).
`step` returns the prediction and its target from before the update (or, with
`after=True`, from after it: `Config.intrinsic_timing`, departure 8); the intrinsic
reward is computed from them by `rewards.intrinsic_reward` (Eq. 4), the one function the
book shows.
"""

from __future__ import annotations

import torch
from torch import nn

from acder_lite.algo.core import mlp


class SICM(nn.Module):
    """S-ICM's forward dynamics model F(s_t, a_t) -> s_{t+1}, with s = (o, g)
    (`Config.sicm_input`: normalised or raw).

    Paper, section V-B: "three-layer fully connected": input [s, a], one hidden layer of
    256 ReLU units, output the dimension of (o, g).
    """

    def __init__(
        self,
        s_dim: int,
        act_dim: int,
        hidden: int = 256,
        lr: float = 1e-3,
        init: str = "xavier",
        device=None,
    ):
        super().__init__()
        self.net = mlp([s_dim + act_dim, hidden, s_dim], init=init)
        if device is not None:  # built on the CPU, then moved: same weights anywhere
            self.to(device)
        self.opt = torch.optim.Adam(self.net.parameters(), lr=lr, fused=True)

    def forward(self, s: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([s, a], dim=-1))

    def errors(self, s, a, s2) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-row 1/2 ||F(s, a) - s'||^2 (Eq. 8 before the mean) and the prediction."""
        pred = self(s, a)
        return 0.5 * (pred - s2).pow(2).sum(-1), pred

    def step(
        self, s, a, s2, after: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """One Adam step on L_F (Eq. 8). Returns (prediction F(s, a), its target s',
        loss), all detached and from before the step, or with `after` the prediction of
        the stepped model (one more forward pass): Eq. 4 is taken of them by
        `rewards.intrinsic_reward`. The loss is always the one the step minimised."""
        err, pred = self.errors(s, a, s2)
        loss = err.mean()
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        self.opt.step()
        if after:
            with torch.no_grad():
                pred = self(s, a)
        return pred.detach(), s2, loss.detach()


class ICM(nn.Module):
    """Pathak et al. 2017: features phi(s), an inverse model a_hat = g(phi(s), phi(s'))
    and a forward model phi_hat(s') = f(phi(s), a).

    Loss = (1 - beta) * L_inverse + beta * L_forward (the paper's beta = 0.2). The
    intrinsic reward is the forward error in feature space,
    1/2 ||phi_hat(s') - phi(s')||^2, clipped to [0, eta] like ACDER's so the two are on
    one scale (a departure: Pathak scales by eta and does not clip). Continuous actions:
    the inverse loss is a mean squared error.
    """

    def __init__(
        self,
        s_dim: int,
        act_dim: int,
        feat_dim: int = 64,
        hidden: int = 256,
        beta: float = 0.2,
        lr: float = 1e-3,
        init: str = "xavier",
        device=None,
    ):
        super().__init__()
        self.beta = beta
        self.phi = mlp([s_dim, hidden, feat_dim], init=init)
        self.inverse = mlp([2 * feat_dim, hidden, act_dim], init=init)
        self.forward_model = mlp([feat_dim + act_dim, hidden, feat_dim], init=init)
        if device is not None:  # before the optimiser: its state lives with the weights
            self.to(device)
        self.opt = torch.optim.Adam(self.parameters(), lr=lr, fused=True)

    def losses(
        self, s, a, s2
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """(per-row forward error, inverse loss, forward loss,
        predicted phi(s'), phi(s'))."""
        f, f2 = self.phi(s), self.phi(s2)
        a_hat = self.inverse(torch.cat([f, f2], -1))
        inv = (a_hat - a).pow(2).sum(-1).mean()
        # The forward loss does not move the features, or phi would collapse to a
        # constant that predicts itself; only the inverse loss trains the encoder. That
        # is our choice (book/departures.md, departure 9): Pathak et al.'s code trains
        # the encoder with both losses.
        pred, target = self.forward_model(torch.cat([f.detach(), a], -1)), f2.detach()
        err = 0.5 * (pred - target).pow(2).sum(-1)
        return err, inv, err.mean(), pred, target

    def step(
        self, s, a, s2, after: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """One Adam step on the ICM loss. Returns (predicted phi(s'), phi(s'), loss),
        detached and from before the step, or with `after` both from the stepped
        networks (the features move too); the reward is Eq. 4 of them, as S-ICM's
        (`rewards.intrinsic_reward`)."""
        err, inv, fwd, pred, target = self.losses(s, a, s2)
        loss = (1 - self.beta) * inv + self.beta * fwd
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        self.opt.step()
        if after:
            with torch.no_grad():
                pred, target = self.losses(s, a, s2)[3:]
        return pred.detach(), target, loss.detach()
