"""Acting in the envs: the trained policy with its normalisers, and the batched rollout.

Used by the trainer (collection and evaluation), `eval`, `diagnose`, `bench` and the
book's scenes. `run_episodes` steps the W envs together with one batched policy call per
step; with a `StepPool` it steps them in parallel threads (MuJoCo's mj_step releases
the GIL), which gives the same arrays bit for bit: every env is stepped exactly as
before, only at the same time.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch

from acder_lite.envs import fetch as E
from acder_lite.algo.core import Actor
from acder_lite.algo.normalizer import Normalizer


class Policy:
    """A trained actor with its normalisers: what `eval` and the book need to act.

    `device` is the actor's (None: the CPU). The normalisers keep their statistics in
    numpy and normalise on the CPU; the normalised batch goes to the device once
    (`inputs`), the actions come back once per batched step (`__call__`): both no-ops on
    the CPU.
    """

    def __init__(
        self,
        actor: Actor,
        o_norm: Normalizer,
        g_norm: Normalizer,
        clip_obs: float,
        device=None,
    ):
        self.actor, self.o_norm, self.g_norm, self.clip_obs = (
            actor,
            o_norm,
            g_norm,
            clip_obs,
        )
        self.device = torch.device("cpu" if device is None else device)

    def inputs(self, o: np.ndarray, g: np.ndarray) -> torch.Tensor:
        """Network input: [normalise(clip(o)), normalise(clip(g))], float32, on the
        device (the hot path: one transfer per batch, the same bits on any device)."""
        c = self.clip_obs
        o_t = torch.as_tensor(o, dtype=torch.float32).clamp(-c, c)
        g_t = torch.as_tensor(g, dtype=torch.float32).clamp(-c, c)
        x = torch.cat([self.o_norm.normalize(o_t), self.g_norm.normalize(g_t)], dim=-1)
        return x.to(self.device)

    @torch.no_grad()
    def __call__(self, o: np.ndarray, g: np.ndarray) -> np.ndarray:
        return self.actor(self.inputs(o, g)).cpu().numpy()  # the envs step on the CPU

    def state_dict(self, env: str, method: str) -> dict:
        a = self.actor
        return dict(
            env=env,
            method=method,
            actor=a.state_dict(),
            o_norm=self.o_norm.state_dict(),
            g_norm=self.g_norm.state_dict(),
            clip_obs=self.clip_obs,
            shape=dict(
                in_dim=a.net[0].in_features,
                act_dim=a.net[-2].out_features,
                hidden=a.net[0].out_features,
                layers=(len(a.net) - 2) // 2,
                max_u=a.max_u,
            ),
            norm=dict(
                o=self.o_norm.size,
                g=self.g_norm.size,
                eps=self.o_norm.eps,
                clip=self.o_norm.clip,
            ),
        )

    @classmethod
    def from_state_dict(cls, d: dict, device=None) -> "Policy":
        """Rebuild the policy `state_dict` wrote, on `device` (None: the CPU);
        CheckpointError (one line) if `d` is not one, checked (keys, numbers, the
        actor's shapes) before anything is built (`io.check_policy`)."""
        from acder_lite.io import check_policy

        check_policy(d)
        s, n = d["shape"], d["norm"]
        actor = Actor(s["in_dim"], s["act_dim"], s["hidden"], s["layers"], s["max_u"])
        actor.load_state_dict(d["actor"])
        actor.to("cpu" if device is None else device)
        o_norm, g_norm = (
            Normalizer(n["o"], n["eps"], n["clip"]),
            Normalizer(n["g"], n["eps"], n["clip"]),
        )
        o_norm.load_state_dict(d["o_norm"])
        g_norm.load_state_dict(d["g_norm"])
        return cls(actor, o_norm, g_norm, d["clip_obs"], device)


class StepPool:
    """`n` threads stepping the envs of a batched step: the calling thread and n - 1
    helpers, thread k taking envs k, k + n, k + 2n, ...

    Trap: one executor task per env (`executor.map` over the W envs) pays a thread
    wake-up for every env at every step, and the calling thread sits idle meanwhile;
    two threads so gained little or nothing over one (measured in experiments/speed/,
    `steppool_ab.py` and its README). Here a step wakes n - 1 helpers once each and the
    caller steps its own share.
    """

    def __init__(self, n: int):
        if n < 2:
            raise ValueError(f"a StepPool needs n >= 2 threads, got {n}")
        self.n = n
        self.helpers = ThreadPoolExecutor(n - 1, thread_name_prefix="step")

    def run(self, fn, items: list) -> None:
        """fn(item) for every item, the shares at the same time; returns when all are
        done and re-raises the first exception of any share here."""
        shares = [items[k :: self.n] for k in range(self.n)]
        futures = [self.helpers.submit(_each, fn, sh) for sh in shares[1:] if sh]
        try:
            _each(fn, shares[0])
        finally:
            for f in futures:
                f.result()

    def shutdown(self) -> None:
        self.helpers.shutdown()


def _each(fn, items) -> None:
    for it in items:
        fn(it)


def run_episodes(envs: list, act, T: int, starts=None, pool=None) -> dict:
    """Roll out one episode in each env,
    stepping them together with one batched `act(o, g)` call.

    `starts(i)` may return a stored start (dict with state, goal or None) for env i.
    `pool` (a `StepPool`, or None: one thread) steps the envs in parallel threads;
    resets stay in order, since `starts` may draw from a shared random stream. Returns
    arrays with a leading env axis: o, ag, state (T+1 steps), g, u (T steps), success
    (last step), novel.
    """
    W = len(envs)
    first = E.observe(envs[0])
    od, gd, sd = (
        first["observation"].size,
        first["desired_goal"].size,
        E.state_size(envs[0]),
    )
    ad = envs[0].action_space.shape[0]
    o = np.empty((W, T + 1, od), np.float32)
    ag = np.empty((W, T + 1, gd), np.float32)
    state = np.empty((W, T + 1, sd), np.float64)
    g = np.empty((W, T, gd), np.float32)
    u = np.empty((W, T, ad), np.float32)
    success = np.zeros(W, bool)
    novel = np.zeros(W, bool)
    goal = np.empty((W, gd), np.float64)
    for i, env in enumerate(envs):
        start = starts(i) if starts is not None else None
        if start is None:
            obs, _ = env.reset()
        else:
            obs = E.restart_from(env, start["state"], start.get("goal"))
            novel[i] = True
        o[i, 0], ag[i, 0], goal[i] = (
            obs["observation"],
            obs["achieved_goal"],
            obs["desired_goal"],
        )
        E.get_state(env, state[i, 0])

    t, a = 0, None

    def step(i: int) -> None:  # step t of env i with a[i]: writes only env i's rows
        obs, ok = E.step(envs[i], a[i])
        o[i, t + 1], ag[i, t + 1] = obs["observation"], obs["achieved_goal"]
        E.get_state(envs[i], state[i, t + 1])
        if t == T - 1:
            success[i] = ok

    envs_i = list(range(W))
    for t in range(T):
        a = act(o[:, t], goal)
        u[:, t], g[:, t] = a, goal
        if pool is None:
            for i in envs_i:
                step(i)
        else:
            pool.run(step, envs_i)
    return dict(o=o, ag=ag, state=state, g=g, u=u, success=success, novel=novel)
