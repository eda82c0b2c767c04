"""The one trainer: rollouts, storage, HER sampling,
rewards, DDPG and curiosity updates.

The paper's protocol in one process (protocol v2, departures 1-3): W envs stepped
together, 2 episodes per worker per cycle, 40 updates per cycle on minibatches of 256*W,
50 cycles an epoch (10 on FetchReach), 20 deterministic test episodes per worker after
each epoch.
A method (`Config.method`) only flips switches here.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import torch

from acder_lite.envs import fetch as E
from acder_lite.envs import multistep as M
from acder_lite.algo.buffer import EpisodeBuffer
from acder_lite.config import Config
from acder_lite.algo.curiosity import ICM, SICM
from acder_lite.algo.ddpg import DDPG
from acder_lite.algo.her import sample_her_transitions
from acder_lite.algo.normalizer import Normalizer
from acder_lite.envs.observations import rotation_indices, sincos_angles
from acder_lite.algo.rewards import goal_factor_target, intrinsic_reward, shaped_reward
from acder_lite.train.rollout import Policy, StepPool, run_episodes
from acder_lite.runs.runfiles import RunFiles, versions
from acder_lite.algo.start_states import StartStateSelector

__all__ = [
    "Trainer",
    "Policy",
    "run_episodes",
    "target_clip",
    "versions",
    "BASE_COLUMNS",
]

BASE_COLUMNS = [
    "epoch",
    "cycle",
    "episodes",
    "env_steps",
    "test_success",
    "train_success",
    "critic_loss",
    "actor_loss",
    "q_mean",
    "wall_s",
]
"""Columns every method writes to progress.csv;
methods add their diagnostics after these."""


def target_clip(
    clip: str, switches: dict, eta: float, gamma: float, bonus: float = 0.0
) -> tuple[float, float]:
    """The range the critic's target y is clipped to
    (`compute_loss_q`), `Config.target_clip`.

    "baselines" (protocol v2, every method): Baselines' [-1/(1-gamma), 0] whatever the
    rewards (its clip_pos_returns), so accumulated curiosity cannot make Q positive.
    "wide" (protocol v1, every method; not Baselines' where r_i or the goal factor is
    in the reward): the rewards lambda * r_her + r_i + bonus lie in
    [bonus - lambda_max, bonus + r_i_max], so y is clipped to that range over
    1 - gamma, lambda_max = 1.5 with the goal factor (Eq. 6), r_i_max = eta when r_i is
    in the reward (Eq. 4), bonus = `Config.reward_bonus`.
    """
    if clip == "baselines":
        return (-1.0 / (1 - gamma), 0.0)
    lam_max = 1.5 if switches["goal_factor"] else 1.0
    r_i_max = eta if switches["curiosity_reward"] else 0.0
    return ((bonus - lam_max) / (1 - gamma), (bonus + r_i_max) / (1 - gamma))


class Trainer:
    """One run of one method on one task: builds the envs, the buffer, DDPG and the
    curiosity model `cfg` asks for, then `train()` runs epochs of `train_cycle` (collect
    episodes, then `update_step`s) and `evaluate` until the stop rule or the budget.

    With `out_dir` it writes the run folder as it goes (`runfiles.RunFiles`:
    config.json, progress.csv a row an evaluation, policy.pt and checkpoint.pt after
    every epoch, done.json at the end), and `state_dict`/`load_state_dict` are what a
    checkpoint holds, so a resumed run goes on to the same numbers. `command` is
    recorded in config.json (default: `sys.argv`).
    """

    def __init__(
        self, cfg: Config, out_dir: str | None = None, command: list[str] | None = None
    ):
        self.cfg = cfg = cfg.resolve()  # a resolved copy; the caller's cfg is unchanged
        self.out_dir, self.command = out_dir, command or sys.argv
        self.files = RunFiles(out_dir) if out_dir else None
        sw = cfg.switches
        torch.set_num_threads(self.cfg.torch_threads)
        torch.manual_seed(cfg.seed)
        self.rng = np.random.default_rng(cfg.seed)
        # cfg.obs: the observation set every env gives (acder_lite.envs.observations);
        # "full" is the env as made, so the rest of the trainer reads whichever
        # vector it is given
        self.envs = [
            E.make_env(cfg.env, seed=s, obs=cfg.obs)
            for s in E.run_env_seeds(cfg.seed, cfg.workers)
        ]
        self.test_envs = [
            E.make_env(cfg.env, seed=s, obs=cfg.obs)
            for s in E.run_env_seeds(cfg.seed, cfg.workers, test=True)
        ]
        n_step = min(cfg.workers, cfg.step_threads or cfg.threads)
        self.pool = StepPool(n_step) if n_step > 1 else None
        env0 = self.envs[0]
        obs = E.observe(env0)
        self.T = E.horizon(cfg.env)
        self.dt = float(env0.dt)
        self.reward_fn = env0.compute_reward
        self.max_u = float(env0.action_space.high[0])
        dims = dict(
            o=obs["observation"].size,
            g=obs["desired_goal"].size,
            u=env0.action_space.shape[0],
            state=E.state_size(env0),
        )
        self.dims = dims
        self.buffer = EpisodeBuffer(cfg.buffer_capacity, self.T, dims)
        self.o_norm = Normalizer(dims["o"], cfg.norm_eps, cfg.norm_clip)
        self.g_norm = Normalizer(dims["g"], cfg.norm_eps, cfg.norm_clip)
        s_dim = dims["o"] + dims["g"]
        # cfg.device: networks, normalised minibatches and gradient steps; simulation,
        # replay, HER sampling and the numpy rewards stay on the CPU
        self.device = dev = torch.device(self.cfg.device)
        self.agent = DDPG(s_dim, dims["u"], cfg, self.max_u, dev)
        self.policy = Policy(
            self.agent.actor, self.o_norm, self.g_norm, cfg.clip_obs, dev
        )
        self.curiosity = None
        # cfg.sicm_angles: S-ICM's input with each Euler angle as (sin, cos), one
        # column more per angle (Config.validate allows it only where a block is seen)
        self.sicm_angles = None
        if sw["curiosity"] == "sicm" and cfg.sicm_angles == "sincos":
            self.sicm_angles = rotation_indices(E.obs_names(env0))
        if sw["curiosity"] == "sicm":
            n_extra = 0 if self.sicm_angles is None else self.sicm_angles.size
            self.curiosity = SICM(
                s_dim + n_extra, dims["u"], cfg.sicm_hidden, cfg.sicm_lr, cfg.init, dev
            )
        elif sw["curiosity"] == "icm":
            self.curiosity = ICM(
                s_dim,
                dims["u"],
                cfg.icm_feature_dim,
                cfg.sicm_hidden,
                cfg.icm_beta,
                cfg.sicm_lr,
                cfg.init,
                dev,
            )
        # the multi-step Push's per-block columns (M.BLOCK_COLUMNS, M.POOL_COLUMN)
        self.multistep = cfg.env == M.ENV_ID
        self.selector = (
            StartStateSelector(cfg.pool_size, cfg.alpha0, cfg.alpha_base)
            if sw["start_states"]
            else None
        )
        self.per = self.ebp = None
        if sw["priority"] == "per":
            from acder_lite.algo.priority import PrioritizedReplay

            self.per = PrioritizedReplay(
                self.buffer.size, self.T, cfg.per_alpha, cfg.per_eps
            )
        elif sw["priority"] == "ebp":
            from acder_lite.algo.priority import EnergyPrioritizer

            self.ebp = EnergyPrioritizer(
                self.buffer.size, temperature=cfg.ebp_temperature
            )
        self.clip_return = target_clip(
            cfg.target_clip, sw, cfg.eta, cfg.gamma, cfg.reward_bonus
        )
        # progress
        self.cycle = 0  # cycles done in all
        self.episodes = 0  # training episodes (all workers)
        self.env_steps = 0
        self.wall = 0.0
        self.success_rate = 0.0  # latest test success (drives Eq. 9)
        self.rows: list[dict] = []
        self.done = False
        # "success held", "gap after first success" or "budget"
        self.stop_reason: str | None = None
        self._reset_diag()

    # ----- columns and diagnostics
    @property
    def columns(self) -> list[str]:
        extra = []
        if self.curiosity is not None:
            extra += ["r_int_mean", "curiosity_loss"]
        if self.cfg.switches["goal_factor"]:
            extra += ["lambda_mean"]
        if self.selector is not None:
            extra += ["alpha", "novel_start_share", "pool_size"]
        if self.per is not None:
            extra += ["per_beta"]
        if self.ebp is not None:
            extra += ["energy_mean"]
        if self.multistep:
            extra += list(M.BLOCK_COLUMNS)
            if self.selector is not None:
                extra += [M.POOL_COLUMN]
        return BASE_COLUMNS + extra

    def _reset_diag(self):
        self.diag = dict(
            n_upd=0,
            critic_loss=0.0,
            actor_loss=0.0,
            q_mean=0.0,
            r_int=0.0,
            cur_loss=0.0,
            lam=0.0,
            n_ep=0,
            n_novel=0,
            n_succ=0,
            energy=0.0,
        )

    # ----- acting
    def explore_act(self, o: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Baselines' exploration: pi + N(0, noise_eps) clipped, then a uniform random
        action with probability random_eps. All random numbers are drawn every call
        (stable random stream)."""
        u = self.policy(o, g)
        noise = self.cfg.noise_eps * self.max_u * self.rng.standard_normal(u.shape)
        u = np.clip(u + noise, -self.max_u, self.max_u)
        rand = self.rng.uniform(-self.max_u, self.max_u, u.shape)
        pick = self.rng.random(u.shape[0]) < self.cfg.random_eps
        return np.where(pick[:, None], rand, u).astype(np.float32)

    def _start(self, i: int):
        """Where env i's next episode starts:
        a stored candidate (probability alpha) or None."""
        cand = self.selector.draw(self.rng)
        if cand is None:
            return None
        return dict(
            state=cand["state"],
            goal=cand["goal"] if self.cfg.restart_goal == "episode" else None,
        )

    # ----- one cycle
    def collect(self) -> dict:
        ep = run_episodes(
            self.envs,
            self.explore_act,
            self.T,
            starts=self._start if self.selector else None,
            pool=self.pool,
        )
        slots = self.buffer.store(ep)
        if self.per is not None:
            self.per.add_episodes(slots)
        if self.ebp is not None:
            from acder_lite.algo.priority import trajectory_energy

            c = self.cfg
            energy = trajectory_energy(
                ep["ag"], self.dt, c.ebp_w_potential, c.ebp_w_kinetic, c.ebp_clip_energy
            )
            self.ebp.add_episodes(slots, energy)
            self.diag["energy"] += float(energy.sum())
        self.update_normalizers(ep)
        W = len(self.envs)
        self.episodes += W
        self.env_steps += W * self.T
        d = self.diag
        d["n_ep"] += W
        d["n_novel"] += int(ep["novel"].sum())
        d["n_succ"] += int(ep["success"].sum())
        return ep

    def update_normalizers(self, ep: dict) -> None:
        """Fit the observation and goal normalisers on the episodes `ep` just
        collected, as Baselines does: on n * T HER-relabelled samples of them (so the
        goal statistics include achieved goals), clipped to `clip_obs`. Trap: it draws
        from the trainer's generator, so calling it outside `collect` changes the
        run's later numbers."""
        n = ep["o"].shape[0]
        tr = sample_her_transitions(
            ep, n * self.T, self.cfg.future_p, self.reward_fn, self.rng
        )
        c = self.cfg.clip_obs
        self.o_norm.update(np.clip(tr["o"], -c, c))
        self.g_norm.update(np.clip(tr["g"], -c, c))

    def sample_batch(self) -> dict:
        B = self.cfg.batch_size * self.cfg.workers
        ep_idx = t_idx = weights = None
        if self.per is not None:
            ep_idx, t_idx, weights = self.per.sample(self.rng, B, self.per_beta)
        elif self.ebp is not None:
            ep_idx = self.ebp.sample_episodes(self.rng, B)
        batch = sample_her_transitions(
            self.buffer.arrays(),
            B,
            self.cfg.future_p,
            self.reward_fn,
            self.rng,
            ep_idx,
            t_idx,
        )
        batch["weights"] = weights
        return batch

    @property
    def per_beta(self) -> float:
        from acder_lite.algo.priority import per_beta

        total = self.cfg.epochs * self.cfg.cycles
        return per_beta(self.cycle / max(1, total), self.cfg.per_beta0)

    def curiosity_step(self, batch: dict, tb: dict) -> np.ndarray | None:
        """One training step of the curiosity model on this minibatch (S-ICM's Eq. 8,
        or ICM's losses), and its intrinsic reward r_i for each row (Eq. 4), float32;
        None for a method without curiosity.

        `Config.intrinsic_timing` says whether r_i is the error before the step (the
        default) or after it."""
        if self.curiosity is None:
            return None
        s, s2 = self.curiosity_inputs(batch, tb)
        pred, target, loss = self.curiosity.step(
            s, tb["u"], s2, after=self.cfg.intrinsic_timing == "after"
        )
        # to the CPU (a no-op there): Eq. 4 and 6 are numpy by design (rewards.py) and
        # the start-state pool keeps numpy rows
        r_int = intrinsic_reward(
            pred.cpu().numpy(), target.cpu().numpy(), self.cfg.eta
        ).astype(np.float32)
        self.diag["r_int"] += float(r_int.mean())
        self.diag["cur_loss"] += float(loss)
        return r_int

    def shaped_rewards(
        self, batch: dict, r_int: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The rewards the critic learns from, r = lambda * r_her + r_i (Eq. 4-6), with
        lambda = 1 on rows HER did not relabel, plus `Config.reward_bonus`; and lambda
        itself (None without the goal factor). A pure function of its inputs.

        r_i stays out of r when the method's `curiosity_reward` switch is off (the
        ablation without curiosity still trains S-ICM for its start states)."""
        sw = self.cfg.switches
        bonus = r_int if sw["curiosity_reward"] else None
        if self.cfg.reward_bonus:  # the curiosity control (Config.reward_bonus)
            c = np.float32(self.cfg.reward_bonus)
            bonus = np.full(len(batch["r"]), c) if bonus is None else bonus + c
        # agent position s^a_t = gripper position, o[:3] (book/departures.md,
        # departure 10); the simplified observation keeps it first
        # (observations.simplified_indices checks it)
        goal = goal_factor_target(batch["g"], batch["ag"])
        rows = batch["her"]  # Config.goal_factor_rows (departure 12)
        if self.cfg.goal_factor_rows == "all":
            rows = np.ones_like(rows)
        r, lam = shaped_reward(
            batch["r"],
            rows,
            batch["o"][:, :3],
            goal,
            batch["u"],
            bonus,
            sw["goal_factor"],
        )
        return r, (lam if sw["goal_factor"] else None)

    def offer_start_states(self, batch: dict, r_int: np.ndarray | None) -> None:
        """Offer this minibatch's most novel state to the start-state pool (Eq. 9's
        candidates, `StartStateSelector.offer`); nothing without start states."""
        if self.selector is not None and r_int is not None:
            self.selector.offer(
                batch, r_int, self.buffer, self.episode_success(batch["ep"])
            )

    def episode_success(self, ep: np.ndarray) -> np.ndarray:
        """Per stored episode index, whether the episode may give a start-state
        candidate (`Config.candidate_success`, departure 16): success at its last step,
        or at any step (read from the stored float32 goals, as HER's rewards are)."""
        if self.cfg.candidate_success == "final":
            return self.buffer.success[ep]
        ag2, g = self.buffer.ag[ep, 1:], self.buffer.g[ep]
        return E.successes(self.envs[0], ag2, g).any(axis=-1)

    def curiosity_inputs(
        self, batch: dict, tb: dict
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """What the curiosity module sees of a minibatch, s = (o, g) and s' = (o2, g).
        S-ICM: the policy's normalised inputs, or the raw ones clipped to clip_obs
        (`Config.sicm_input`), the Euler angles as (sin, cos) with
        `Config.sicm_angles="sincos"`. ICM (her-icm) always the normalised ones: it
        learns its own features of them, and the readings measured S-ICM's input
        only."""
        if self.cfg.sicm_input == "normalised" or not isinstance(self.curiosity, SICM):
            return tb["x"], tb["x2"]
        c = self.cfg.clip_obs
        g = torch.as_tensor(batch["g"], dtype=torch.float32)

        def cat(o):  # built on the CPU, moved once: the same bits on every device
            if self.sicm_angles is not None:
                o = sincos_angles(o, self.sicm_angles)
            s = torch.cat([torch.as_tensor(o, dtype=torch.float32), g], -1).clamp(-c, c)
            return s.to(self.device)

        return cat(batch["o"]), cat(batch["o2"])

    def batch_tensors(self, batch: dict) -> dict:
        """The networks' inputs of a minibatch:
        normalised (o, g) as x, (o2, g) as x2, and u."""
        u = torch.from_numpy(np.ascontiguousarray(batch["u"])).to(self.device)
        return dict(
            x=self.policy.inputs(batch["o"], batch["g"]),
            x2=self.policy.inputs(batch["o2"], batch["g"]),
            u=u,
        )

    def update_step(self) -> dict:
        """One update of ACDER (or of a baseline: a step a method does not have is
        skipped), each step once and in this order."""
        batch = self.sample_batch()  # the minibatch, HER-relabelled (her.py)
        tb = self.batch_tensors(batch)  # normalised network inputs
        r_int = self.curiosity_step(batch, tb)  # Eq. 8's step; r_i of Eq. 4
        r, lam = self.shaped_rewards(batch, r_int)  # Eq. 4-6, pure
        if lam is not None:
            self.diag["lam"] += float(lam.mean())
        self.offer_start_states(batch, r_int)  # Eq. 9's candidates
        tb["r"] = torch.from_numpy(r).to(self.device)
        w = batch["weights"]
        w = None if w is None else torch.from_numpy(w).to(self.device)
        out = self.agent.update(tb, self.clip_return, w)
        if self.per is not None:  # the sum tree is numpy: TD errors come back once
            self.per.update(batch["ep"], batch["t"], out["td"].cpu().numpy())
        d = self.diag
        d["n_upd"] += 1
        d["critic_loss"] += float(out["critic_loss"])
        d["actor_loss"] += float(out["actor_loss"])
        return out

    def train_cycle(self) -> None:
        for _ in range(self.cfg.episodes_per_cycle):
            self.collect()
        for _ in range(self.cfg.updates_per_cycle):
            self.update_step()
        self.agent.update_targets()
        self.cycle += 1

    @torch.no_grad()
    def evaluate(self) -> float:
        """Mean is_success at the last step of test_episodes deterministic episodes per
        worker. Also `q_mean`: the critic's Q(s_0, pi(s_0)) at the test episodes' first
        states (Baselines' test/mean_Q averages Q over every step instead); on the
        multi-step Push, each block's shares of these episodes (`M.block_shares`, read
        from their arrays: no random number drawn)."""
        succ, q, ag, g = [], [], [], []
        for _ in range(self.cfg.test_episodes):
            ep = run_episodes(self.test_envs, self.policy, self.T, pool=self.pool)
            succ.append(ep["success"])
            x = self.policy.inputs(ep["o"][:, 0], ep["g"][:, 0])
            q.append(self.agent.critic(x, self.agent.actor(x)).cpu().numpy())
            ag.append(ep["ag"])
            g.append(ep["g"][:, -1])
        self.diag["q_mean"] = float(np.mean(np.concatenate(q))) if q else float("nan")
        if self.multistep:
            threshold = float(self.test_envs[0].distance_threshold)
            if ag:
                self.diag.update(
                    M.block_shares(np.concatenate(ag), np.concatenate(g), threshold)
                )
            else:
                self.diag.update(dict.fromkeys(M.BLOCK_COLUMNS, float("nan")))
        return float(np.mean(np.concatenate(succ))) if succ else float("nan")

    # ----- the run
    def log_row(self, wall_start: float) -> dict:
        self.success_rate = self.evaluate()
        if self.selector is not None:
            self.selector.set_success_rate(self.success_rate)
        d, n = self.diag, max(1, self.diag["n_upd"])
        row = dict(
            epoch=self.cycle / self.cfg.cycles,
            cycle=self.cycle,
            episodes=self.episodes,
            env_steps=self.env_steps,
            test_success=self.success_rate,
            train_success=d["n_succ"] / max(1, d["n_ep"]),
            critic_loss=d["critic_loss"] / n,
            actor_loss=d["actor_loss"] / n,
            q_mean=d["q_mean"],
            wall_s=self.wall + time.perf_counter() - wall_start,
            r_int_mean=d["r_int"] / n,
            curiosity_loss=d["cur_loss"] / n,
            lambda_mean=d["lam"] / n,
            novel_start_share=d["n_novel"] / max(1, d["n_ep"]),
            energy_mean=d["energy"] / max(1, d["n_ep"]),
        )
        if self.selector is not None:
            row.update(alpha=self.selector.alpha, pool_size=len(self.selector.pool))
        if self.multistep:
            row.update({k: d[k] for k in M.BLOCK_COLUMNS})
            if self.selector is not None:
                row[M.POOL_COLUMN] = self.pool_block_on_target()
        if self.per is not None:
            row["per_beta"] = self.per_beta
        row = {k: row[k] for k in self.columns}  # only this method's diagnostics
        self.rows.append(row)
        self._reset_diag()
        return row  # written to progress.csv by `train`, after its checkpoint

    def pool_block_on_target(self) -> float:
        """Share of the start-state pool's candidates with at least one block within
        distance_threshold of its own target (`M.POOL_COLUMN`; NaN for an empty pool).
        The target is the candidate's stored goal, that of the episode it came from
        (with `restart_goal="resample"`, the default, a restarted episode gets a fresh
        goal). The blocks' positions are read from the stored MuJoCo states
        (`E.site_positions`: no env stepped, no random number drawn), as float32 like
        the buffer's achieved goals; the pool stores nothing more for it, so older
        checkpoints' pools read the same."""
        pool = self.selector.pool
        if not pool:
            return float("nan")
        env = self.test_envs[0]
        states = np.stack([c["state"] for c in pool])
        goals = np.stack([c["goal"] for c in pool])
        ag = E.site_positions(env, states, M.OBJECTS).reshape(len(pool), -1)
        on = M.any_block_on_target(ag.astype(np.float32), goals, env.distance_threshold)
        return float(on.mean())

    def should_stop(self) -> bool:
        """The stop rule: test success >= success_threshold at the last stop_patience
        evaluations."""
        c = self.cfg
        if c.stop_patience <= 0 or len(self.rows) < c.stop_patience:
            return False
        return all(
            r["test_success"] >= c.success_threshold
            for r in self.rows[-c.stop_patience :]
        )

    def past_gap(self) -> bool:
        """stop_gap_episodes training episodes or more since the test success first
        reached success_threshold (protocol v1; checked at epoch ends only, so the run
        ends on a checkpoint)."""
        c = self.cfg
        if c.stop_gap_episodes <= 0:
            return False
        # the first crossing exactly as Table I reads it
        from acder_lite.stats.report import episodes_to_threshold

        first = episodes_to_threshold(self.rows, c.success_threshold)
        return first is not None and self.episodes >= first + c.stop_gap_episodes

    def train(self, progress: bool = True, max_cycles: int | None = None) -> list[dict]:
        """Train until cfg.epochs (or the early stop), checkpointing after every epoch.

        `max_cycles` pauses the run after that many cycles in all, as an interrupt at
        that point would (no done.json; `--resume` continues). On KeyboardInterrupt the
        last end-of-epoch checkpoint stays on disk (it is written atomically), so
        `--resume` continues from there; the interrupt is re-raised.
        """
        from tqdm import tqdm

        c = self.cfg
        total = c.epochs * c.cycles
        if self.out_dir:
            self.write_config()
            if self.rows:  # a resumed run: drop rows logged after its checkpoint
                self.files.write_progress(self.rows, self.columns)
        stop_at = total if max_cycles is None else min(total, max_cycles)
        bar = tqdm(
            total=total,
            initial=self.cycle,
            disable=not progress,
            unit="cycle",
            dynamic_ncols=True,
            file=sys.stderr,
        )
        t0 = time.perf_counter()
        try:
            while self.cycle < stop_at and not self.done:
                self.train_cycle()
                bar.update(1)
                end_of_epoch = self.cycle % c.cycles == 0
                logged = end_of_epoch or (
                    c.eval_every_cycles and self.cycle % c.eval_every_cycles == 0
                )
                if logged:
                    row = self.log_row(t0)
                    bar.set_postfix(
                        success=f"{row['test_success']:.2f}", episodes=self.episodes
                    )
                    if self.should_stop():
                        self.done, self.stop_reason = True, "success held"
                if end_of_epoch and not self.done and self.past_gap():
                    self.done, self.stop_reason = True, "gap after first success"
                if end_of_epoch or self.done:
                    self.wall += time.perf_counter() - t0
                    t0 = time.perf_counter()
                    if self.files:
                        self.files.save(self.state_dict(), self.policy_state())
                if logged and self.files and self.files.checkpoint_cycle is not None:
                    # a row reaches progress.csv once a checkpoint is on disk (an
                    # epoch's, after its own), so a run killed or failing before its
                    # first leaves no progress.csv to refuse; a mid-epoch row past the
                    # last checkpoint is dropped on resume (`train` above)
                    self.files.write_progress(self.rows, self.columns)
            if not self.done and self.cycle >= total:
                self.done, self.stop_reason = True, "budget"
        finally:
            bar.close()
        if self.files and self.done:
            self.files.write_done(
                dict(
                    epochs=self.cycle / c.cycles,
                    episodes=self.episodes,
                    stopped_early=self.cycle < total,
                    stop_reason=self.stop_reason,
                    stop_rule=dict(
                        success_threshold=c.success_threshold,
                        patience=c.stop_patience,
                        budget_epochs=c.epochs,
                        gap_episodes=c.stop_gap_episodes,
                    ),
                    final_test_success=self.success_rate,
                    wall_s=self.wall,
                )
            )
        return self.rows

    # ----- files
    def write_config(self) -> None:
        """config.json (`RunFiles.write_config`):
        a resumed run appends its command under "resumes"."""
        self.files.write_config(
            self.cfg.to_dict(), self.cfg.seed, " ".join(self.command), self.cycle
        )

    def policy_state(self) -> dict:
        # obs: what the policy sees, so eval, robust and export rebuild its input
        # (io.check_policy); trained: how far the run had got when it was saved, which
        # the export's metadata carries to the robot
        return dict(
            self.policy.state_dict(self.cfg.env, self.cfg.method),
            obs=self.cfg.obs,
            trained=dict(
                epochs=self.cycle / self.cfg.cycles,
                episodes=self.episodes,
                test_success=self.rows[-1]["test_success"] if self.rows else None,
            ),
        )

    def state_dict(self) -> dict:
        """Everything a resumed run needs to continue with the same numbers."""
        return dict(
            config=self.cfg.to_dict(),
            policy=self.policy_state(),
            agent=self.agent.state_dict(),
            o_norm=self.o_norm.state_dict(),
            g_norm=self.g_norm.state_dict(),
            curiosity=None if self.curiosity is None else self.curiosity.state_dict(),
            curiosity_opt=None
            if self.curiosity is None
            else self.curiosity.opt.state_dict(),
            selector=None if self.selector is None else self.selector.state_dict(),
            per=None if self.per is None else self.per.state_dict(),
            ebp=None if self.ebp is None else self.ebp.state_dict(),
            buffer=self.buffer.state_dict(),
            progress=dict(
                cycle=self.cycle,
                episodes=self.episodes,
                env_steps=self.env_steps,
                wall=self.wall,
                success_rate=self.success_rate,
                rows=self.rows,
                done=self.done,
                stop_reason=self.stop_reason,
            ),
            rng=dict(
                numpy=self.rng.bit_generator.state,
                torch=torch.get_rng_state(),
                envs=[E.env_rng_state(e) for e in self.envs],
                test_envs=[E.env_rng_state(e) for e in self.test_envs],
            ),
            versions=versions(),
        )

    def load_state_dict(self, d: dict) -> None:
        self.agent.load_state_dict(d["agent"])
        self.o_norm.load_state_dict(d["o_norm"])
        self.g_norm.load_state_dict(d["g_norm"])
        if self.curiosity is not None:
            self.curiosity.load_state_dict(d["curiosity"])
            self.curiosity.opt.load_state_dict(d["curiosity_opt"])
        for name in ("selector", "per", "ebp"):
            if getattr(self, name) is not None:
                getattr(self, name).load_state_dict(d[name])
        self.buffer.load_state_dict(d["buffer"])
        p = d["progress"]
        self.cycle, self.episodes, self.env_steps = (
            p["cycle"],
            p["episodes"],
            p["env_steps"],
        )
        self.wall, self.success_rate, self.rows, self.done = (
            p["wall"],
            p["success_rate"],
            p["rows"],
            p["done"],
        )
        # absent from checkpoints written before it was recorded
        self.stop_reason = p.get("stop_reason")
        if self.files:  # the checkpoint this run goes on from is on disk
            self.files.checkpoint_cycle = self.cycle
        r = d["rng"]
        self.rng.bit_generator.state = r["numpy"]
        torch.set_rng_state(r["torch"])
        for e, s in zip(self.envs, r["envs"]):
            E.set_env_rng_state(e, s)
        for e, s in zip(self.test_envs, r["test_envs"]):
            E.set_env_rng_state(e, s)
