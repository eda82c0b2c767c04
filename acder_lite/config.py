"""All settings of a run in one dataclass, the method table, and per-task presets.

A method is a set of switches on the one trainer (book/using.md, "Extending it"):
`METHODS` maps each `--method` name to those switches. Every decision the paper leaves
open is a field here, with the default book/departures.md gives and argues.
"""

from __future__ import annotations

import copy

import dataclasses
import math
import numbers
from dataclasses import dataclass, field, fields

from acder_lite.legacy import LEGACY_METHODS, upgrade_legacy  # noqa: F401

ENV_IDS = (
    "FetchReach-v4",
    "FetchPush-v4",
    "FetchPickAndPlace-v4",
    "FetchSlide-v4",
    "FetchPushMultiStep-v0",
)
"""The goal-based Fetch tasks this package trains on (gymnasium-robotics 1.4.2, `-v4`
ids), and the paper's multi-step task in our reading, two blocks with a target each
(`acder_lite.envs.multistep`)."""

OBJECT_ENVS = (
    "FetchPush-v4",
    "FetchPickAndPlace-v4",
    "FetchSlide-v4",
    "FetchPushMultiStep-v0",
)
"""Tasks with an object (EBP's energy is defined on the object, so it needs one)."""

# method -> switches. her: HER relabelling; curiosity: none | sicm | icm (the module
# trained on each minibatch); curiosity_reward: r_i is added to the reward; goal_factor:
# Eq. 5-6; start_states: dynamic initial-state selection (Eq. 9), ranked by S-ICM's r_i;
# priority: none | per | ebp. Ablation "without curiosity" (Fig. 5): S-ICM still ranks
# the start-state candidates (section IV-B needs its r_i), but r_i leaves the reward.
# Without S-ICM no candidate could be chosen, and the ablation would silently lose its
# start states too.
# The critic's target clip is not a switch of a method but a setting of every run
# (`Config.target_clip`): protocol v2 gives every method Baselines' [-1/(1-gamma), 0].
METHODS: dict[str, dict] = {
    "ddpg": dict(
        her=False,
        curiosity="none",
        curiosity_reward=False,
        goal_factor=False,
        start_states=False,
        priority="none",
    ),
    "her": dict(
        her=True,
        curiosity="none",
        curiosity_reward=False,
        goal_factor=False,
        start_states=False,
        priority="none",
    ),
    "her-icm": dict(
        her=True,
        curiosity="icm",
        curiosity_reward=True,
        goal_factor=False,
        start_states=False,
        priority="none",
    ),
    "her-per": dict(
        her=True,
        curiosity="none",
        curiosity_reward=False,
        goal_factor=False,
        start_states=False,
        priority="per",
    ),
    "her-ebp": dict(
        her=True,
        curiosity="none",
        curiosity_reward=False,
        goal_factor=False,
        start_states=False,
        priority="ebp",
    ),
    "acder": dict(
        her=True,
        curiosity="sicm",
        curiosity_reward=True,
        goal_factor=True,
        start_states=True,
        priority="none",
    ),
    "acder-no-curiosity": dict(
        her=True,
        curiosity="sicm",
        curiosity_reward=False,
        goal_factor=True,
        start_states=True,
        priority="none",
    ),
    "acder-no-goal-factor": dict(
        her=True,
        curiosity="sicm",
        curiosity_reward=True,
        goal_factor=False,
        start_states=True,
        priority="none",
    ),
    "acder-no-start-states": dict(
        her=True,
        curiosity="sicm",
        curiosity_reward=True,
        goal_factor=True,
        start_states=False,
        priority="none",
    ),
}

SWITCHES = dict(
    her=(False, True),
    curiosity=("none", "sicm", "icm"),
    curiosity_reward=(False, True),
    goal_factor=(False, True),
    start_states=(False, True),
    priority=("none", "per", "ebp"),
)
"""Every switch of a `METHODS` entry and the values it may take."""


def switches_problem(method: str, switches: dict) -> str | None:
    """What is wrong with a `METHODS` entry, as one line, or None. Trap: the trainer
    builds what the switches name and nothing else, so a misspelt switch or value
    (curiosity="rnd") would train a run without that part, silently; and start
    states are ranked by the curiosity module's r_i, so they need one."""
    if set(switches) != set(SWITCHES):
        return (
            f"METHODS[{method!r}] has switches {sorted(switches)}; "
            f"allowed: exactly {sorted(SWITCHES)}"
        )
    for name, allowed in SWITCHES.items():
        if switches[name] not in allowed or type(switches[name]) is not type(
            allowed[0]
        ):
            return (
                f"METHODS[{method!r}][{name!r}]={switches[name]!r} is not allowed: "
                f"one of {', '.join(map(repr, allowed))}"
            )
    if switches["start_states"] and switches["curiosity"] == "none":
        return (
            f"METHODS[{method!r}] has start_states without a curiosity module; "
            "allowed: curiosity 'sicm' or 'icm' (its r_i ranks the candidates)"
        )
    if switches["curiosity_reward"] and switches["curiosity"] == "none":
        return (
            f"METHODS[{method!r}] has curiosity_reward without a curiosity module; "
            "allowed: curiosity 'sicm' or 'icm'"
        )
    return None


# Paper, section V-B: eta = 0.05 on Reach, 0.8 elsewhere; alpha0 = 0.8 (0.7 on the
# multi-step task); 25 / 50 / 100 epochs. Table I: Reach counts episodes to 100% test
# success, Push and Pick&Place to 95%. Baselines' experiment/config.py: FetchReach's
# epochs have 10 cycles, the others 50. gamma: Baselines' experiment/config.py sets
# gamma = 1 - 1/T from the episode's horizon T (0.98 at T = 50, 0.99 at T = 100); its
# clip_return = 1/(1 - gamma) follows (tests/test_protocol.py checks the rule per task).
TASK_PRESETS: dict[str, dict] = {
    "FetchReach-v4": dict(
        eta=0.05, alpha0=0.8, epochs=25, cycles=10, success_threshold=1.0, gamma=0.98
    ),
    "FetchPush-v4": dict(
        eta=0.8, alpha0=0.8, epochs=50, cycles=50, success_threshold=0.95, gamma=0.98
    ),
    "FetchPickAndPlace-v4": dict(
        eta=0.8, alpha0=0.8, epochs=100, cycles=50, success_threshold=0.95, gamma=0.98
    ),
    "FetchSlide-v4": dict(
        eta=0.8, alpha0=0.8, epochs=50, cycles=50, success_threshold=0.95, gamma=0.98
    ),
    # the multi-step task (section V-B: alpha0 = 0.7, 400 epochs; Table I's 95% rule)
    "FetchPushMultiStep-v0": dict(
        eta=0.8, alpha0=0.7, epochs=400, cycles=50, success_threshold=0.95, gamma=0.99
    ),
}

PRESET_FIELDS = ("eta", "alpha0", "epochs", "cycles", "success_threshold", "gamma")
"""Config fields whose None means "the task's preset" (filled by `Config.resolve`)."""

TARGET_CLIPS = ("baselines", "wide")
INITS = ("xavier", "torch")
BUFFER_SCOPES = ("worker", "shared")
SICM_INPUTS = ("normalised", "raw")
SICM_ANGLES = ("euler", "sincos")
OBS_SETS = ("full", "simplified")
"""Allowed `Config.obs` values (`acder_lite.envs.observations`)."""
MAX_WORKERS = 500
"""The most envs a run steps together: `envs.run_env_seeds` gives test env i the seed
`seed*1000+500+i`, so training env 500 would reset to test env 0's goals."""
MAX_THREADS = 1024
"""The most threads a run (or bench, robust, a sweep's cell) takes: above the hardware
threads of any machine this runs on (a two-socket server of today has 768), a fixed
number so a config reads the same on every machine. Trap: torch passed 2**31 - 1 on to
libgomp, whose thread table for it (230 GB) failed: "out of memory", exit 1."""
THREADS_ALLOWED = (
    f"an integer in [1, {MAX_THREADS}] (more threads than any machine this runs on has)"
)
"""What a threads option allows, in its one-line error."""

SPLIT_UPDATES = ("auto", "on", "off")
"""Allowed `Config.split_update` values."""
UPDATE_DTYPES = ("auto", "float32", "bfloat16")
"""Allowed `Config.update_dtype` values."""
DEVICES = ("auto", "cpu", "cuda")
"""Allowed `Config.device` values."""


class ConfigError(ValueError):
    """A bad setting. The message is one line naming the field and what is allowed."""


@dataclass
class Config:
    # --- what to run
    env: str = "FetchReach-v4"
    """Gymnasium id of the task, one of `ENV_IDS` (`train --help` lists them)."""
    method: str = "her"
    """A row of the method table (`METHODS`, which `train --help` lists): DDPG, the
    paper's baselines, ACDER and its ablations (protocol v1's acder-baselines-clip is
    acder with today's default target clip)."""
    seed: int = 0
    """Seeds numpy, torch and every env
    (worker i gets `seed*1000+i`, test envs `seed*1000+500+i`: `envs.run_env_seeds`)."""
    obs: str = "full"
    """What the policy (and S-ICM) sees of the observation: 'full' (the Fetch vector:
    positions, rotations, velocities) or 'simplified' (paper, section V-E, for the UR5:
    gripper position, object positions, object-minus-gripper positions, finger states;
    no velocities or rotations: `acder_lite.envs.observations`). A config.json
    without the field is 'full', as every earlier run."""

    # --- the paper protocol
    # (Baselines' DDPG+HER, 4 MPI workers emulated in one process)
    workers: int = 4
    """W envs stepped together; stands in for the paper's W MPI workers. At most
    `MAX_WORKERS`: past it a training env would share its seed with a test env."""
    epochs: int | None = None
    """Training epochs; the run's budget.
    None: the task preset (paper: Reach 25, Push 50, Pick&Place 100, Multi-step Push
    400; ours: Slide 50)."""
    cycles: int | None = None
    """Cycles per epoch.
    None: the task preset (Baselines: 10 on FetchReach, 50 elsewhere)."""
    episodes_per_cycle: int = 2
    """Episodes each worker collects per cycle (Baselines' rollout_batch_size)."""
    updates_per_cycle: int = 40
    """Gradient steps per cycle (Baselines' n_batches)."""
    batch_size: int = 256
    """Minibatch per worker;
    one update uses batch_size*workers transitions (gradients averaged)."""
    test_episodes: int = 20
    """Deterministic test episodes per worker after each epoch (Baselines:
    n_test_rollouts=10 x rollout_batch_size=2; protocol v1 used 10)."""
    eval_every_cycles: int = 0
    """Also evaluate every N cycles (0: only at the end of each epoch, protocol v2).
    Protocol v1 used 5 (0.1 epoch at 50 cycles); Table I's statistic now interpolates
    between epoch evaluations instead (`report`)."""
    buffer_size: int = 1_000_000
    """Replay capacity in transitions (episodes of T steps are stored whole), per worker
    when `buffer_scope` is 'worker'."""
    buffer_scope: str = "worker"
    """'worker': the buffer holds buffer_size transitions per worker, as each Baselines
    MPI worker keeps its own 10^6 (one shared buffer of W x buffer_size, sampled
    uniformly); 'shared': buffer_size in all (protocol v1)."""

    # --- DDPG (Baselines' defaults)
    hidden: int = 256
    """Units per hidden layer of actor and critic."""
    layers: int = 3
    """Hidden layers of actor and critic."""
    init: str = "xavier"
    """Weights of every network: 'xavier' (Baselines' nn(): Xavier-uniform weights, zero
    biases) or 'torch' (PyTorch's nn.Linear default, protocol v1)."""
    target_clip: str = "baselines"
    """Range of the critic's target y: 'baselines' ([-1/(1-gamma), 0], Baselines'
    clip_pos_returns, for every method) or 'wide' ([bonus - lambda_max, bonus + r_i_max]
    / (1 - gamma) with bonus = `reward_bonus`, the range the method's shaped rewards can
    reach (`trainer.target_clip`): protocol v1, for every method,
    where it differed from Baselines' for ACDER, its ablations and HER+ICM; departure
    13)."""
    lr_actor: float = 1e-3
    """Adam learning rate of the actor."""
    lr_critic: float = 1e-3
    """Adam learning rate of the critic."""
    gamma: float | None = None
    """Discount factor, in [0, 1). None: the task preset, Baselines' 1 - 1/T for the
    task's horizon T (0.98 on the 50-step Fetch tasks, 0.99 on the 100-step multi-step
    Push); Baselines' target clip [-1/(1-gamma), 0] follows from it."""
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
    """HER 'future' strategy:
    relabel a share 1 - 1/(1+k) of each minibatch (0.8 for k=4)."""

    # --- ACDER (section IV) and baselines' own knobs
    eta: float | None = None
    """Eq. 4 clip of the intrinsic reward, in (0, 1).
    None: the task preset (0.05 Reach, 0.8 else)."""
    alpha0: float | None = None
    """Eq. 9 initial ratio of novel starts, in [0, 1]. None: the task preset (0.8; 0.7
    on FetchPushMultiStep-v0, section V-B)."""
    sicm_hidden: int = 256
    """Hidden units of S-ICM's forward model (paper: one hidden layer of 256; 3 layers
    in all), and of ICM's networks for her-icm."""
    sicm_input: str = "raw"
    """What S-ICM sees and predicts (Eq. 7-8): 'raw' (o, g), clipped to clip_obs only,
    or 'normalised' (o, g), the policy's inputs. The paper does not say;
    experiments/readings/ measured both on Push (3 seeds each): the runs do not separate
    them, so the paper's eta values (0.05 on Reach, 0.8 elsewhere: raw-scale errors)
    decide (departure 6). S-ICM only: HER+ICM's ICM always sees the normalised ones."""
    sicm_angles: str = "euler"
    """How S-ICM sees each block's orientation (`object_rot`, three Euler angles in
    [-pi, pi]): 'euler' as the observation gives them (the paper's), or 'sincos', each
    angle theta as (sin theta, cos theta), which does not jump by 2 pi when the block
    turns through +-pi (`observations.sincos_angles`). Not the paper's: an experiment on
    what Eq. 4 pays for such wraps (experiments/sicm-sincos/, departure 6). S-ICM only,
    on raw inputs, on tasks with a block in the observation; the policy, the critic and
    ICM see the observation unchanged."""
    sicm_lr: float = 1e-3
    """Adam learning rate of the forward model (S-ICM or ICM)."""
    intrinsic_timing: str = "before"
    """Which forward model gives a minibatch its r_i (Eq. 4): the one from 'before' its
    own step on that minibatch (Eq. 7-8; the step's forward pass serves both) or the
    one from 'after' it (one more forward pass). The paper trains the curiosity module
    on the policy's minibatch and does not say which (departure 8). S-ICM and ICM."""
    alpha_base: float = 10 * math.e
    """The base written `10e` in Eq. 9, alpha = alpha0 - 0.5 * alpha_base^(success - 1):
    read as 10 times Euler's number, 27.18 (departure 14). A finite number > 1; the
    larger, the longer alpha stays near alpha0 as success grows (alpha is
    alpha0 - 0.5 / alpha_base at success 0 and alpha0 - 0.5 at success 1, whatever
    the base)."""
    pool_size: int = 50
    """How many of the most recent candidate start states are kept."""
    candidate_success: str = "final"
    """Which episodes may give a start-state candidate (section IV-B: "transitions that
    stem from successful episodes"): 'final', success at the episode's last step (how
    a test episode is scored), or 'any', success at any of its steps (departure 16)."""
    restart_goal: str = "resample"
    """Goal of an episode restarted from a stored state:
    'resample' (fresh) or 'episode' (stored)."""
    goal_factor_rows: str = "relabelled"
    """Which minibatch rows get the goal-oriented factor lambda of Eq. 5-6:
    'relabelled' (the rows HER gave a hindsight goal g^h; the others keep lambda = 1)
    or 'all' (every row, its own goal or a relabelled one). The paper applies it "for
    transitions after HER modification" and writes Eq. 5 with g^h, which reads either
    way (departure 12). Without the goal factor (`acder-no-goal-factor`) it has no
    effect."""
    reward_bonus: float = 0.0
    """A constant added to every minibatch reward, beside r_i where the method has one:
    r = lambda * r_her + r_i + reward_bonus. Not the paper's: a control for curiosity
    (experiments/constant-bonus/). On Push, HER+ICM's bonus grows toward its clip eta
    and varies little from one transition to the next, so a constant of its size asks
    how much of HER+ICM's gain comes from shifting every reward rather than from
    novelty. 0 (the default): nothing is added. A number in [-1, 1]."""
    icm_feature_dim: int = 64
    """ICM (Pathak et al.): size of the learned feature embedding."""
    icm_beta: float = 0.2
    """ICM: weight of the forward loss against the inverse loss."""
    per_alpha: float = 0.6
    """PER: priority exponent."""
    per_beta0: float = 0.4
    """PER: importance-sampling exponent at the start,
    annealed linearly to 1 over the run."""
    per_eps: float = 1e-6
    """PER: added to |TD error| so no priority is zero."""
    ebp_clip_energy: float = 0.5
    """EBP: clip of each step's energy transition (Zhao & Tresp's clip_energy)."""
    ebp_w_potential: float = 1.0
    """EBP: weight of potential energy."""
    ebp_w_kinetic: float = 1.0
    """EBP: weight of kinetic energy."""
    ebp_temperature: float | None = None
    """EBP: None (the default) samples episodes exactly in proportion to their energy; a
    number T > 0 first raises each energy to the power 1/(T + 0.01), as Zhao & Tresp's
    code does (its default T = 1: an exponent of 1/1.01; departure 22)."""

    # --- engineering
    threads: int = 2
    """CPU threads of the run (2 uses both cores of this machine): torch's intra-op
    threads, split between the two loss threads under `split_update`, and by default the
    threads stepping the envs (`step_threads`). At most 1024 (`MAX_THREADS`)."""
    step_threads: int = 0
    """Threads stepping the W envs at once in collection and evaluation (MuJoCo releases
    the GIL). 0: `threads` when it is above 1, else one (sequential). The rollout is the
    same bit for bit either way (`rollout.run_episodes`); only the time differs."""
    split_update: str = "auto"
    """Compute the critic's and the actor's loss (forward and backward) at the same
    time, in two threads (`DDPG.update`): 'on', 'off' (one thread computes both, as
    protocol v1 and every run before this setting did), or 'auto' ('on' when
    `threads` >= 2). On, torch runs on threads // 2 intra-op threads (at least 1) in
    each of the two threads, instead of `threads` in one: two chains of small matmuls
    on a core each beat one chain whose every op is split over both cores
    (experiments/speed/README.md). The losses share no trained tensor, so the numbers
    are those of a one-thread update on the same intra-op threads: at threads=2 a run
    equals the threads=1 run bit for bit (tests/test_rollout.py)."""
    compile_update: bool = False
    """Compile the critic's and the actor's loss, forward and backward, with
    torch.compile (inductor; `acder_lite.algo.compiled`): the matmuls stay MKL's, the
    ops between them are fused. It moves floats: the fused ops round in another order,
    so a run's weights equal the eager ones within float32 tolerance only
    (tests/test_compiled.py), not bit for bit. Off by default, and off for the
    reproduction grid, whose runs resume across code changes and must compute as they
    started (experiments/bit-identity/). The first update compiles (tens of seconds, a
    few from inductor's on-disk cache); then it is a little cheaper than eager
    (experiments/speed/README.md). A resumed run keeps its checkpoint's setting."""
    update_dtype: str = "auto"
    """Precision of the actor/critic gradient step: 'auto' (times the update's own
    shapes, this run's minibatch, hidden size and layers on its threads, in both
    precisions, about a second, and takes bfloat16 only where it measured at least 1.2x
    faster; float32 elsewhere, and without timing on a CPU with no native bfloat16
    matmul: `precision.choose_update_dtype`), 'float32', or 'bfloat16' (CPU autocast:
    the matmuls in bf16; weights, gradients, Adam and losses stay fp32). Its speed
    depends on the machine, from 2-3x faster per update to slower than float32
    (experiments/speed/README.md; `bench --update-dtype both` measures yours); it is a
    different computation: compare
    learning curves before mixing its runs with float32 ones. Acting, evaluation and
    S-ICM stay fp32. `resolve` replaces 'auto' by the choice; config.json records it
    and why (the two timings), and a resumed run keeps it."""
    update_dtype_why: str = ""
    """Filled by `resolve()`:
    why update_dtype is what it is (recorded in config.json)."""
    device: str = "auto"
    """Where the networks, the normalised minibatches and every gradient step live:
    'auto' (CUDA where torch sees a device, else the CPU), 'cpu' or 'cuda' (an error
    without CUDA). Simulation, replay and the numpy rewards stay on the CPU; actions
    come back once per batched step. `resolve` replaces 'auto' by the choice;
    config.json records it and why. A resumed run may change it
    (`--resume DIR --device cpu`); the checkpoint loads onto it."""
    device_why: str = ""
    """Filled by `resolve()`: why device is what it is (recorded in config.json)."""
    success_threshold: float | None = None
    """Test success rate Table I counts episodes to and the stop rule holds. None: the
    task preset (paper: Reach 1.0, Push and Pick&Place 0.95; ours: 0.95 on Slide and
    the multi-step Push)."""
    stop_patience: int = 5
    """The stop rule: end the run once test success >= success_threshold at this many
    evaluations in a row (with eval_every_cycles=0, epoch evaluations); 0: always run
    the budget. The mean curve carries a stopped seed's last 5 evaluations forward
    (`report`)."""
    stop_gap_episodes: int = 0
    """Protocol v1 only: also stop at the first epoch end this many training episodes
    after the test success first reached success_threshold (0: off)."""

    switches: dict = field(default_factory=dict)
    """Filled from `METHODS[method]` by `resolve()`; recorded in config.json."""

    def resolve(self) -> "Config":
        """A validated copy with the task presets (`PRESET_FIELDS`), the method's
        switches, and the `auto` device and update dtype filled in (the dtype by timing
        this run's update in both precisions, about a second the first time a process
        meets its shape: `precision.choose_update_dtype`; a dtype with its why recorded,
        as a resumed run's, is kept); `self` is left as it was (the trap it avoids: a
        caller's Config changing under it)."""
        self.validate()
        c = copy.copy(self)
        preset = TASK_PRESETS[c.env]
        for name in PRESET_FIELDS:
            if getattr(c, name) is None:
                setattr(c, name, preset[name])
        c.switches = dict(METHODS[c.method])
        from acder_lite.precision import choose_device, choose_update_dtype

        try:  # also checks that a recorded 'cuda' (a resumed run) is still there
            device, why = choose_device(c.device)
        except ValueError as e:
            raise ConfigError(str(e)) from None
        if c.device == "auto" or not c.device_why:
            c.device, c.device_why = device, why
        # a recorded choice (a resumed run's config) stays: only 'auto' is measured
        if c.update_dtype == "auto" or not c.update_dtype_why:
            c.update_dtype, c.update_dtype_why = choose_update_dtype(
                c.update_dtype,
                c.device,
                rows=c.batch_size * c.workers,
                hidden=c.hidden,
                layers=c.layers,
                threads=c.torch_threads,
            )
        c.validate()
        return c

    @property
    def split(self) -> bool:
        """Whether the two losses run at once (`split_update`, 'auto' resolved)."""
        return self.split_update == "on" or (
            self.split_update == "auto" and self.threads >= 2
        )

    @property
    def torch_threads(self) -> int:
        """torch's intra-op threads: `threads`, or half of them in each loss thread."""
        return max(1, self.threads // 2) if self.split else self.threads

    @property
    def episodes_per_epoch(self) -> int:
        """Training episodes an epoch: cycles x episodes_per_cycle x workers (400 under
        the paper's protocol; 80 on Reach, whose epochs have 10 cycles). Resolve first:
        a task preset may set the cycles."""
        return self.cycles * self.episodes_per_cycle * self.workers

    @property
    def future_p(self) -> float:
        return (
            1.0 - 1.0 / (1.0 + self.replay_k) if self.switches.get("her", True) else 0.0
        )

    def validate(self) -> None:
        """Raise ConfigError (one line: field, value, what is allowed)
        on the first bad field."""

        def bad(name, allowed):
            raise ConfigError(
                f"{name}={getattr(self, name)!r} is not allowed: {allowed}"
            )

        for f in fields(self):  # a number of the wrong type (config.json, a plan)
            v, kind = getattr(self, f.name), _NUMBER_TYPES.get(str(f.type))
            if kind is None or (v is None and str(f.type).endswith("| None")):
                continue
            if isinstance(v, bool) or not isinstance(v, kind[0]):
                bad(f.name, kind[1])
            # past int64 a size was torch's or numpy's traceback (seed: its own range)
            if kind[0] is numbers.Integral and f.name != "seed" and v >= 2**63:
                bad(f.name, "an integer below 2**63")
        if self.env not in ENV_IDS:
            bad("env", "one of " + ", ".join(ENV_IDS))
        if self.method in LEGACY_METHODS:
            method, clip = LEGACY_METHODS[self.method]
            raise ConfigError(
                f"method={self.method!r} is protocol v1's name; "
                f"allowed: --method {method} "
                f"(its target clip, {clip!r}, is today's default)"
            )
        if self.method not in METHODS:
            bad("method", "one of " + ", ".join(METHODS))
        problem = switches_problem(self.method, METHODS[self.method])
        if problem:
            raise ConfigError(problem)
        if METHODS[self.method]["priority"] == "ebp" and self.env not in OBJECT_ENVS:
            raise ConfigError(
                f"method={self.method!r} needs a task with an object; "
                f"env={self.env!r} has none (allowed: {', '.join(OBJECT_ENVS)})"
            )
        for name in (
            "workers",
            "epochs",
            "cycles",
            "episodes_per_cycle",
            "batch_size",
            "hidden",
            "layers",
            "sicm_hidden",
            "pool_size",
            "icm_feature_dim",
            "threads",
        ):
            if name in PRESET_FIELDS and getattr(self, name) is None:
                continue
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                bad(name, "an integer >= 1")
        if self.workers > MAX_WORKERS:
            bad(
                "workers",
                f"an integer in [1, {MAX_WORKERS}] (envs.run_env_seeds: worker "
                f"{MAX_WORKERS} would get test env 0's seed)",
            )
        if self.threads > MAX_THREADS:
            bad("threads", THREADS_ALLOWED)
        # 0 test episodes: every evaluation a NaN (progress.csv, done.json, export)
        if not isinstance(self.test_episodes, int) or self.test_episodes < 1:
            bad("test_episodes", "an integer >= 1 (each evaluation's episodes)")
        for name in (
            "updates_per_cycle",
            "eval_every_cycles",
            "replay_k",
            "stop_patience",
            "stop_gap_episodes",
            "step_threads",
        ):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 0:
                bad(name, "an integer >= 0")
        if not 0 <= self.seed < 2**64:  # torch.manual_seed's range; gym's is >= 0
            bad("seed", "an integer in [0, 2**64)")
        if self.buffer_size < 1000:
            bad("buffer_size", "an integer >= 1000")
        for name in ("lr_actor", "lr_critic", "sicm_lr"):
            if not 0 < getattr(self, name) < math.inf:
                bad(name, "a finite number > 0")
        for name in ("gamma", "polyak"):
            if name in PRESET_FIELDS and getattr(self, name) is None:
                continue
            if not 0 <= getattr(self, name) < 1:
                bad(name, "a number in [0, 1)")
        for name in ("noise_eps", "random_eps", "per_alpha", "per_beta0"):
            if not 0 <= getattr(self, name) <= 1:
                bad(name, "a number in [0, 1]")
        if self.success_threshold is not None and not 0 < self.success_threshold <= 1:
            bad("success_threshold", "a number in (0, 1]")
        for name, allowed in (
            ("target_clip", TARGET_CLIPS),
            ("init", INITS),
            ("buffer_scope", BUFFER_SCOPES),
            ("sicm_input", SICM_INPUTS),
            ("sicm_angles", SICM_ANGLES),
            ("split_update", SPLIT_UPDATES),
        ):
            if getattr(self, name) not in allowed:
                bad(name, " or ".join(repr(x) for x in allowed))
        for name in (
            "action_l2",
            "clip_obs",
            "norm_eps",
            "norm_clip",
            "per_eps",
            "ebp_clip_energy",
            "ebp_w_potential",
            "ebp_w_kinetic",
            "icm_beta",
        ):
            if not getattr(self, name) >= 0:
                bad(name, "a number >= 0")
        # inf here: a NaN loss, normaliser or priority, or (the clips) a policy.pt
        # that `io.check_policy` refuses; 0 for norm_eps: a constant entry is 0/0
        for name in (
            "action_l2",
            "clip_obs",
            "norm_clip",
            "per_eps",
            "ebp_w_potential",
            "ebp_w_kinetic",
        ):
            if not getattr(self, name) < math.inf:
                bad(name, "a finite number >= 0")
        if not 0 < self.norm_eps < math.inf:
            bad("norm_eps", "a finite number > 0")
        if self.ebp_temperature is not None and not 0 < self.ebp_temperature < math.inf:
            bad("ebp_temperature", "a finite number > 0, or unset (exponent 1)")
        if not self.icm_beta <= 1:
            bad("icm_beta", "a number in [0, 1] (the forward loss's weight)")
        if self.eta is not None and not 0 < self.eta < 1:
            bad("eta", "a number in (0, 1) (paper, Eq. 4)")
        if self.alpha0 is not None and not 0 <= self.alpha0 <= 1:
            bad("alpha0", "a number in [0, 1] (paper, Eq. 9)")
        if not -1 <= self.reward_bonus <= 1:  # also refuses nan
            bad("reward_bonus", "a number in [-1, 1]")
        if self.restart_goal not in ("resample", "episode"):
            bad("restart_goal", "'resample' or 'episode'")
        if self.goal_factor_rows not in ("relabelled", "all"):
            bad("goal_factor_rows", "'relabelled' or 'all'")
        if self.candidate_success not in ("final", "any"):
            bad("candidate_success", "'final' or 'any'")
        if self.intrinsic_timing not in ("before", "after"):
            bad("intrinsic_timing", "'before' or 'after'")
        if not 1 < self.alpha_base < math.inf:
            bad("alpha_base", "a finite number > 1 (Eq. 9's base, read as 10e)")
        if not isinstance(self.compile_update, bool):
            bad("compile_update", "True or False (the flag --compile-update)")
        if self.update_dtype not in UPDATE_DTYPES:
            bad("update_dtype", " or ".join(repr(x) for x in UPDATE_DTYPES))
        if self.device not in DEVICES:
            bad("device", " or ".join(repr(x) for x in DEVICES))
        if self.obs not in OBS_SETS:
            bad("obs", " or ".join(repr(x) for x in OBS_SETS))
        if self.sicm_angles == "sincos":  # (sin, cos) of the raw angles, of a block's
            if self.sicm_input != "raw":
                bad(
                    "sicm_angles",
                    "'euler' with sicm_input='normalised' ('sincos' "
                    "encodes the raw angles: sicm_input='raw')",
                )
            if self.env not in OBJECT_ENVS or self.obs == "simplified":
                bad(
                    "sicm_angles",
                    f"'euler' on {self.env} or with obs='simplified' "
                    "(their observation has no block's Euler angles)",
                )

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @property
    def buffer_capacity(self) -> int:
        """Transitions the one replay buffer holds (`buffer_scope`)."""
        return self.buffer_size * (self.workers if self.buffer_scope == "worker" else 1)

    @classmethod
    def from_dict(cls, d: dict) -> "Config":
        """A Config from config.json's "config" (or a checkpoint's). A dict written
        before a field existed (protocol v1) gets the value that run used
        (`LEGACY_VALUES`)."""
        d = upgrade_legacy(d)
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ConfigError(
                f"unknown config field {unknown[0]!r}; "
                f"allowed: {', '.join(sorted(known))}"
            )
        return cls(**d)


_NUMBER_TYPES = {
    "int": (numbers.Integral, "an integer"),
    "int | None": (numbers.Integral, "an integer"),
    "float": (numbers.Real, "a number"),
    "float | None": (numbers.Real, "a number"),
}
"""A number field's annotation -> (the types its value may have, numpy's included;
what to call them in `Config.validate`'s one line). A bool is no number here: True
is no seed."""


def fast_mode() -> bool:
    """True when ACDER_FAST=1 (set by `make test`):
    budgets shrink, the code path stays the same."""
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
        if (
            isinstance(a, ast.AnnAssign)
            and isinstance(b, ast.Expr)
            and isinstance(getattr(b, "value", None), ast.Constant)
        ):
            docs[a.target.id] = " ".join(str(b.value.value).split())
    return docs
