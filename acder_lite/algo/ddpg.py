"""DDPG as in Baselines' HER: one function per loss, and the agent that steps both.

Each loss takes a batch of tensors (`x` = normalised [o, g], `x2` = normalised [o2, g],
`u`, `r`) so a test can call it on a fixed batch.
"""

from __future__ import annotations

import copy
from concurrent.futures import ThreadPoolExecutor

import torch

from acder_lite.algo.core import Actor, Critic, frozen_view


def compute_loss_q(
    critic,
    actor_targ,
    critic_targ,
    batch: dict,
    gamma: float,
    clip_return: tuple[float, float],
    weights: torch.Tensor | None = None,
):
    """Eq. 1-2: L = mean_i w_i (y_i - Q(s_i, a_i))^2
    with y_i = r_i + gamma Q'(s_{i+1}, pi'(s_{i+1})).

    y is clipped to `clip_return` (Baselines' [-1/(1-gamma), 0] for every method;
    `target_clip="wide"` widens it for curiosity's rewards, departure 13). No terminal
    masking: Fetch episodes only end by the time limit. `weights` are PER's importance
    weights (None: all 1). Returns (loss, td_error) with td_error = y - Q, detached.
    """
    with torch.no_grad():
        q_next = critic_targ(batch["x2"], actor_targ(batch["x2"]))
        y = (batch["r"] + gamma * q_next).clamp_(*clip_return)
    q = critic(batch["x"], batch["u"])
    td = y - q
    sq = td.pow(2)
    loss = sq.mean() if weights is None else (weights * sq).mean()
    return loss, td.detach()


def compute_loss_pi(actor, critic, batch: dict, action_l2: float):
    """Eq. 3 as a loss: -mean Q(s, pi(s)) + action_l2 * mean (pi(s)/max_u)^2
    (Baselines' penalty).

    Trap: the critic's weights must not be trained by this loss: pass a view that
    shares them without gradients (`core.frozen_view`, as `DDPG.update` does).
    """
    pi = actor(batch["x"])
    return -critic(batch["x"], pi).mean() + action_l2 * (pi / actor.max_u).pow(2).mean()


class DDPG:
    """Actor, critic, their targets and Adam optimisers, on `device` (None: the CPU).

    The networks are initialised on the CPU and then moved, so a seed gives the same
    weights on every device; `update`'s batches must be on it (`Trainer.batch_tensors`).
    `cfg.split` (`Config.split_update`): `update` computes the two losses at the same
    time, the actor's in a second thread. `cfg.compile_update`: both losses under
    torch.compile (`compiled.compile_loss`); off, `loss_q` and `loss_pi` are the
    functions above themselves.
    """

    def __init__(self, in_dim: int, act_dim: int, cfg, max_u: float = 1.0, device=None):
        self.cfg = cfg
        self.device = torch.device("cpu" if device is None else device)
        # .to(cpu) is a no-op: the CPU path holds the very tensors it always held
        shape = (in_dim, act_dim, cfg.hidden, cfg.layers, max_u, cfg.init)
        self.actor = Actor(*shape).to(self.device)
        self.critic = Critic(*shape).to(self.device)
        self.actor_targ = copy.deepcopy(self.actor).requires_grad_(False)
        self.critic_targ = copy.deepcopy(self.critic).requires_grad_(False)
        # the critic as the actor's loss sees it: its weights, without their gradients
        self.critic_frozen = frozen_view(self.critic)
        self.loss_q, self.loss_pi = compute_loss_q, compute_loss_pi
        if cfg.compile_update:  # opt-in: moves floats (Config.compile_update)
            from acder_lite.algo.compiled import compile_loss

            self.loss_q = compile_loss(compute_loss_q)
            self.loss_pi = compile_loss(compute_loss_pi)
        # compiled losses compile on their first call: let one thread make both
        self.compiled_once = not cfg.compile_update
        self.actor_thread = (
            ThreadPoolExecutor(1, thread_name_prefix="actor-loss")
            if cfg.split
            else None
        )
        # fused: one kernel per optimiser step instead of ~10 small ops per tensor
        # (about a tenth of an update step: experiments/speed/README.md).
        self.pi_opt = torch.optim.Adam(
            self.actor.parameters(), lr=cfg.lr_actor, fused=True
        )
        self.q_opt = torch.optim.Adam(
            self.critic.parameters(), lr=cfg.lr_critic, fused=True
        )

    def _autocast(self):
        """bf16 matmuls for the forward passes when `cfg.update_dtype` is 'bfloat16'
        (backward follows the forward's dtypes; the fp32 weights and their gradients are
        untouched)."""
        return torch.autocast(
            self.device.type,
            dtype=torch.bfloat16,
            enabled=self.cfg.update_dtype == "bfloat16",
        )

    def update(self, batch: dict, clip_return, weights=None) -> dict:
        """One gradient step of critic and actor, both computed with the critic before
        its step (as Baselines does in one session run). Returns the losses and the
        signed TD error y - Q(s, a) per row (PER takes its absolute value).

        The two losses share no trained tensor (the actor's sees the critic through
        `critic_frozen`), so they may run at once: with `actor_thread` the actor's
        forward and backward run in it while this thread does the critic's (torch
        releases the GIL inside its ops). Each op runs as it would alone, so the
        result is the same bit for bit; the steps come after both. Compiled losses
        (`cfg.compile_update`) compile in this thread, one after the other, on the
        first update.
        """

        def critic_grads():
            with self._autocast():
                q_loss, td = self.loss_q(
                    self.critic,
                    self.actor_targ,
                    self.critic_targ,
                    batch,
                    self.cfg.gamma,
                    clip_return,
                    weights,
                )
            self.q_opt.zero_grad(set_to_none=True)
            q_loss.backward()
            return q_loss, td

        def actor_grads():
            with self._autocast():  # autocast is per thread: enter it in this one
                pi_loss = self.loss_pi(
                    self.actor, self.critic_frozen, batch, self.cfg.action_l2
                )
            self.pi_opt.zero_grad(set_to_none=True)
            pi_loss.backward()
            return pi_loss

        if self.actor_thread is None or not self.compiled_once:
            q_loss, td = critic_grads()
            pi_loss = actor_grads()
            self.compiled_once = True
        else:
            future = self.actor_thread.submit(actor_grads)
            try:
                q_loss, td = critic_grads()
            finally:
                pi_loss = future.result()  # waits, and re-raises the thread's error
        self.q_opt.step()
        self.pi_opt.step()
        return dict(critic_loss=q_loss.detach(), actor_loss=pi_loss.detach(), td=td)

    @torch.no_grad()
    def update_targets(self) -> None:
        """Polyak averaging: target <- polyak * target + (1 - polyak) * main."""
        p = self.cfg.polyak
        for net, targ in (
            (self.actor, self.actor_targ),
            (self.critic, self.critic_targ),
        ):
            for a, b in zip(targ.parameters(), net.parameters()):
                a.mul_(p).add_(b, alpha=1 - p)

    def state_dict(self) -> dict:
        return dict(
            actor=self.actor.state_dict(),
            critic=self.critic.state_dict(),
            actor_targ=self.actor_targ.state_dict(),
            critic_targ=self.critic_targ.state_dict(),
            pi_opt=self.pi_opt.state_dict(),
            q_opt=self.q_opt.state_dict(),
        )

    def load_state_dict(self, d: dict) -> None:
        for k in ("actor", "critic", "actor_targ", "critic_targ", "pi_opt", "q_opt"):
            getattr(self, k).load_state_dict(d[k])
