"""All settings of a run in one dataclass, the method table, and per-task presets.

A method is a set of switches on the one trainer (DESIGN.md, "Data flow"): `METHODS` maps each
`--method` name to those switches. Every decision the paper leaves open is a field here, with the
default DESIGN.md fixes.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields

ENV_IDS = ("FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4", "FetchSlide-v4")
"""The goal-based Fetch tasks this package trains on (gymnasium-robotics 1.4.2, `-v4` ids)."""

OBJECT_ENVS = ("FetchPush-v4", "FetchPickAndPlace-v4", "FetchSlide-v4")
"""Tasks with an object (EBP's energy is defined on the object, so it needs one)."""

# method -> switches. her: HER relabelling; curiosity: none | sicm | icm (the module trained on each
# minibatch); curiosity_reward: r_i is added to the reward; goal_factor: Eq. 5-6; start_states:
# dynamic initial-state selection (Eq. 9), ranked by S-ICM's r_i; priority: none | per | ebp.
# Ablation "without curiosity" (Fig. 5): S-ICM still ranks the start-state candidates (section IV-B
# needs its r_i), but r_i leaves the reward. Without S-ICM no candidate could be chosen, and the
# ablation would silently lose its start states too.
# target_clip: the range the critic's target y is clipped to. "wide" (DESIGN.md) is the range the
# method's rewards can reach, [-lambda_max, r_i_max] / (1 - gamma); "baselines" is Baselines' own
# [-1/(1-gamma), 0] (clip_pos_returns), which the paper's Baselines-based code may have kept: it
# stops Q from growing on accumulated curiosity. `acder-baselines-clip` is ACDER with it, an
# experiment of ours (not in the paper) on why our ACDER differs from the paper's.
METHODS: dict[str, dict] = {
    "ddpg": dict(her=False, curiosity="none", curiosity_reward=False, goal_factor=False, start_states=False, priority="none", target_clip="wide"),
    "her": dict(her=True, curiosity="none", curiosity_reward=False, goal_factor=False, start_states=False, priority="none", target_clip="wide"),
    "her-icm": dict(her=True, curiosity="icm", curiosity_reward=True, goal_factor=False, start_states=False, priority="none", target_clip="wide"),
    "her-per": dict(her=True, curiosity="none", curiosity_reward=False, goal_factor=False, start_states=False, priority="per", target_clip="wide"),
    "her-ebp": dict(her=True, curiosity="none", curiosity_reward=False, goal_factor=False, start_states=False, priority="ebp", target_clip="wide"),
    "acder": dict(her=True, curiosity="sicm", curiosity_reward=True, goal_factor=True, start_states=True, priority="none", target_clip="wide"),
    "acder-no-curiosity": dict(her=True, curiosity="sicm", curiosity_reward=False, goal_factor=True, start_states=True, priority="none", target_clip="wide"),
    "acder-no-goal-factor": dict(her=True, curiosity="sicm", curiosity_reward=True, goal_factor=False, start_states=True, priority="none", target_clip="wide"),
    "acder-no-start-states": dict(her=True, curiosity="sicm", curiosity_reward=True, goal_factor=True, start_states=False, priority="none", target_clip="wide"),
    "acder-baselines-clip": dict(her=True, curiosity="sicm", curiosity_reward=True, goal_factor=True, start_states=True, priority="none", target_clip="baselines"),
}

# Paper, section V-B: eta = 0.05 on Reach, 0.8 elsewhere; alpha0 = 0.8 (0.7 on the multi-step task).
TASK_PRESETS: dict[str, dict] = {
    "FetchReach-v4": dict(eta=0.05, alpha0=0.8),
    "FetchPush-v4": dict(eta=0.8, alpha0=0.8),
    "FetchPickAndPlace-v4": dict(eta=0.8, alpha0=0.8),
    "FetchSlide-v4": dict(eta=0.8, alpha0=0.8),
}


UPDATE_DTYPES = ("float32", "bfloat16")
"""Allowed `Config.update_dtype` values."""


class ConfigError(ValueError):
    """A bad setting. The message is one line naming the field and what is allowed."""


@dataclass
class Config:
    # --- what to run
    env: str = "FetchReach-v4"
    """Gymnasium id of the task; one of `ENV_IDS`."""
    method: str = "her"
    """A row of the method table (`METHODS`): ddpg, her, her-icm, her-per, her-ebp, acder, ablations,
    acder-baselines-clip."""
    seed: int = 0
    """Seeds numpy, torch and every env (worker i gets seed*1000+i, test envs seed*1000+500+i)."""

    # --- the paper protocol (Baselines' DDPG+HER, 4 MPI workers emulated in one process)
    workers: int = 4
    """W envs stepped together; stands in for the paper's W MPI workers."""
    epochs: int = 50
    """Training epochs (Reach 25, Push 50, Pick&Place 100 in the paper)."""
    cycles: int = 50
    """Cycles per epoch."""
    episodes_per_cycle: int = 2
    """Episodes each worker collects per cycle (Baselines' rollout_batch_size)."""
    updates_per_cycle: int = 40
    """Gradient steps per cycle (Baselines' n_batches)."""
    batch_size: int = 256
    """Minibatch per worker; one update uses batch_size*workers transitions (gradients averaged)."""
    test_episodes: int = 10
    """Deterministic test episodes per worker after each epoch."""
    eval_every_cycles: int = 0
    """Also evaluate every N cycles (0: only at the end of each epoch). Table I suggests 5."""
    buffer_size: int = 1_000_000
    """Replay capacity in transitions (episodes of T steps are stored whole)."""

    # --- DDPG (Baselines' defaults)
    hidden: int = 256
    """Units per hidden layer of actor and critic."""
    layers: int = 3
    """Hidden layers of actor and critic."""
    lr_actor: float = 1e-3
    """Adam learning rate of the actor."""
    lr_critic: float = 1e-3
    """Adam learning rate of the critic."""
    gamma: float = 0.98
    """Discount factor."""
    polyak: float = 0.95
    """Target <- polyak*target + (1-polyak)*main, once per cycle."""
    action_l2: float = 1.0
    """L2 penalty on the actor's (pre-scaled) actions."""
    noise_eps: float = 0.2
    """Std of the Gaussian exploration noise, as a fraction of max action."""
    random_eps: float = 0.3
    """Probability of replacing the action by a uniformly random one while training."""
    clip_obs: float = 200.0
    """Observations and goals are clipped to +-clip_obs before normalising."""
    norm_eps: float = 0.01
    """Lower bound on the normaliser's std."""
    norm_clip: float = 5.0
    """Normalised inputs are clipped to +-norm_clip."""

    # --- HER
    replay_k: int = 4
    """HER 'future' strategy: relabel a share 1 - 1/(1+k) of each minibatch (0.8 for k=4)."""

    # --- ACDER (section IV) and baselines' own knobs
    eta: float | None = None
    """Eq. 4 clip of the intrinsic reward, in (0, 1). None: the task preset (0.05 Reach, 0.8 else)."""
    alpha0: float | None = None
    """Eq. 9 initial ratio of novel starts, in [0, 1]. None: the task preset (0.8)."""
    sicm_hidden: int = 256
    """Hidden units of S-ICM's forward model (paper: one hidden layer of 256; 3 layers in all)."""
    sicm_lr: float = 1e-3
    """Adam learning rate of the forward model (S-ICM or ICM)."""
    pool_size: int = 50
    """How many of the most recent candidate start states are kept."""
    restart_goal: str = "resample"
    """Goal of an episode restarted from a stored state: 'resample' (fresh) or 'episode' (stored)."""
    icm_feature_dim: int = 64
    """ICM (Pathak et al.): size of the learned feature embedding."""
    icm_beta: float = 0.2
    """ICM: weight of the forward loss against the inverse loss."""
    per_alpha: float = 0.6
    """PER: priority exponent."""
    per_beta0: float = 0.4
    """PER: importance-sampling exponent at the start, annealed linearly to 1 over the run."""
    per_eps: float = 1e-6
    """PER: added to |TD error| so no priority is zero."""
    ebp_clip_energy: float = 0.5
    """EBP: clip of each step's energy transition (Zhao & Tresp's clip_energy)."""
    ebp_w_potential: float = 1.0
    """EBP: weight of potential energy."""
    ebp_w_kinetic: float = 1.0
    """EBP: weight of kinetic energy."""

    # --- engineering
    threads: int = 2
    """torch intra-op threads (2 uses both cores of this machine)."""
    update_dtype: str = "float32"
    """Precision of the actor/critic gradient step: 'float32', or 'bfloat16' (CPU autocast: the
    matmuls in bf16; weights, gradients, Adam and losses stay fp32). bfloat16 is about 3x faster
    per update on CPUs with AVX512-BF16 (measured: `bench --update-dtype`) but is a different
    computation: compare learning curves before mixing its runs with float32 ones. Acting,
    evaluation and S-ICM (whose errors are the intrinsic reward) stay fp32."""
    stop_after_success: float = 0.0
    """Stop early once test success >= this for `stop_patience` evaluations in a row (0: never)."""
    stop_patience: int = 3
    """See `stop_after_success`."""
    stop_gap_episodes: int = 0
    """Also stop at the first epoch end at least this many training episodes after the test
    success first reached `stop_after_success` (0: off). Table I counts that first crossing, so a
    run that hovers just below its threshold would spend the rest of its budget for nothing;
    results/ uses 1,200 (three epochs), the rule of results/scripts/end_when_hovering.sh."""

    switches: dict = field(default_factory=dict)
    """Filled from `METHODS[method]` by `resolve()`; recorded in config.json."""

    def resolve(self) -> "Config":
        """Validate, then fill presets (eta, alpha0) and the method's switches. Returns self."""
        self.validate()
        preset = TASK_PRESETS[self.env]
        if self.eta is None:
            self.eta = preset["eta"]
        if self.alpha0 is None:
            self.alpha0 = preset["alpha0"]
        self.switches = dict(METHODS[self.method])
        self.validate()
        return self

    @property
    def future_p(self) -> float:
        return 1.0 - 1.0 / (1.0 + self.replay_k) if self.switches.get("her", True) else 0.0

    def validate(self) -> None:
        """Raise ConfigError (one line: field, value, what is allowed) on the first bad field."""
        def bad(name, allowed):
            raise ConfigError(f"{name}={getattr(self, name)!r} is not allowed: {allowed}")

        if self.env not in ENV_IDS:
            bad("env", "one of " + ", ".join(ENV_IDS))
        if self.method not in METHODS:
            bad("method", "one of " + ", ".join(METHODS))
        if METHODS[self.method]["priority"] == "ebp" and self.env not in OBJECT_ENVS:
            raise ConfigError(f"method={self.method!r} needs a task with an object; "
                              f"env={self.env!r} has none (allowed: {', '.join(OBJECT_ENVS)})")
        for name in ("workers", "epochs", "cycles", "episodes_per_cycle", "batch_size", "hidden",
                     "layers", "sicm_hidden", "pool_size", "icm_feature_dim", "threads", "stop_patience"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                bad(name, "an integer >= 1")
        for name in ("updates_per_cycle", "test_episodes", "eval_every_cycles", "replay_k", "stop_gap_episodes"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 0:
                bad(name, "an integer >= 0")
        if self.buffer_size < 1000:
            bad("buffer_size", "an integer >= 1000")
        for name in ("lr_actor", "lr_critic", "sicm_lr"):
            if not getattr(self, name) > 0:
                bad(name, "a number > 0")
        for name in ("gamma", "polyak"):
            if not 0 <= getattr(self, name) < 1:
                bad(name, "a number in [0, 1)")
        for name in ("noise_eps", "random_eps", "per_alpha", "per_beta0", "stop_after_success"):
            if not 0 <= getattr(self, name) <= 1:
                bad(name, "a number in [0, 1]")
        for name in ("action_l2", "clip_obs", "norm_eps", "norm_clip", "per_eps", "ebp_clip_energy",
                     "ebp_w_potential", "ebp_w_kinetic", "icm_beta"):
            if not getattr(self, name) >= 0:
                bad(name, "a number >= 0")
        if self.eta is not None and not 0 < self.eta < 1:
            bad("eta", "a number in (0, 1) (paper, Eq. 4)")
        if self.alpha0 is not None and not 0 <= self.alpha0 <= 1:
            bad("alpha0", "a number in [0, 1] (paper, Eq. 9)")
        if self.restart_goal not in ("resample", "episode"):
            bad("restart_goal", "'resample' or 'episode'")
        if self.update_dtype not in UPDATE_DTYPES:
            bad("update_dtype", " or ".join(repr(x) for x in UPDATE_DTYPES))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "Config":
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ConfigError(f"unknown config field {unknown[0]!r}; allowed: {', '.join(sorted(known))}")
        return cls(**d)


def fast_mode() -> bool:
    """True when ACDER_FAST=1 (set by `make test`): budgets shrink, the code path stays the same."""
    import os
    return os.environ.get("ACDER_FAST", "0") not in ("", "0")


def field_docs() -> dict[str, str]:
    """The docstring under each Config field (used for the CLI's --help)."""
    import ast
    import inspect
    tree = ast.parse(inspect.getsource(Config))
    body = tree.body[0].body
    docs = {}
    for a, b in zip(body, body[1:]):
        if isinstance(a, ast.AnnAssign) and isinstance(b, ast.Expr) and isinstance(getattr(b, "value", None), ast.Constant):
            docs[a.target.id] = " ".join(str(b.value.value).split())
    return docs
