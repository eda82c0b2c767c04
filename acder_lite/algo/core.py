"""Networks: the actor, the critic
(Baselines' HER: 3x256 ReLU MLPs) and a generic MLP."""

from __future__ import annotations

import copy

import torch
from torch import nn


def mlp(
    sizes: list[int], out_act: type[nn.Module] | None = None, init: str = "xavier"
) -> nn.Sequential:
    """Linear layers of `sizes` with ReLU between them (and `out_act` after the last).

    init 'xavier': Baselines' `nn()` (her/util.py: tf.layers.dense with
    xavier_initializer and the default zero bias); 'torch': PyTorch's nn.Linear default
    (Kaiming-uniform, protocol v1).
    """
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        layer = nn.Linear(sizes[i], sizes[i + 1])
        if init == "xavier":
            nn.init.xavier_uniform_(layer.weight)
            nn.init.zeros_(layer.bias)
        layers.append(layer)
        if i < len(sizes) - 2:
            layers.append(nn.ReLU())
    if out_act is not None:
        layers.append(out_act())
    return nn.Sequential(*layers)


class Actor(nn.Module):
    """pi(o, g) = max_u * tanh(MLP([o_norm, g_norm]))."""

    def __init__(
        self,
        in_dim: int,
        act_dim: int,
        hidden: int = 256,
        layers: int = 3,
        max_u: float = 1.0,
        init: str = "xavier",
    ):
        super().__init__()
        self.max_u = max_u
        self.net = mlp([in_dim] + [hidden] * layers + [act_dim], nn.Tanh, init)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # .float(): under bf16 autocast the layers return bf16; losses and actions stay
        # fp32 (a no-op, no copy, in fp32)
        return self.max_u * self.net(x).float()


class Critic(nn.Module):
    """Q(o, g, u) = MLP([o_norm, g_norm, u / max_u])."""

    def __init__(
        self,
        in_dim: int,
        act_dim: int,
        hidden: int = 256,
        layers: int = 3,
        max_u: float = 1.0,
        init: str = "xavier",
    ):
        super().__init__()
        self.max_u = max_u
        self.net = mlp([in_dim + act_dim] + [hidden] * layers + [1], init=init)

    def forward(self, x: torch.Tensor, u: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([x, u / self.max_u], dim=-1)).float().squeeze(-1)


def frozen_view(net: nn.Module) -> nn.Module:
    """A copy of `net` whose parameters are `net`'s own tensors, detached: it computes
    what `net` computes with the weights of the moment, and a loss through it trains
    nothing of `net` (its weights get no gradient).

    Trap: the usual way, `net.requires_grad_(False)` around a second loss, changes a
    flag the first loss's graph also reads: with both losses computed at once in two
    threads (`DDPG.update`), one thread's flag would switch the other's gradients off.
    The view shares storage, so in-place updates (Adam's step, `load_state_dict`) reach
    it; a `.to(device)` of `net` afterwards would not: build the view after moving.
    """
    view = copy.deepcopy(net)
    for (name, _), p in zip(list(view.named_parameters()), net.parameters()):
        owner_name, _, leaf = name.rpartition(".")
        setattr(
            view.get_submodule(owner_name),
            leaf,
            nn.Parameter(p.detach(), requires_grad=False),
        )
    return view
