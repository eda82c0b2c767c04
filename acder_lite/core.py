"""Networks: the actor, the critic
(Baselines' HER: 3x256 ReLU MLPs) and a generic MLP."""

from __future__ import annotations

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
