"""ACDER Lite: DDPG, HER, S-ICM curiosity, the goal-oriented factor and dynamic start
states (Li et al., "ACDER: Augmented Curiosity-Driven Experience Replay") on the MuJoCo
Fetch tasks.

The package in layers, bottom to top; a folder imports only from the folders below it:

    config, legacy, io, precision, signals, words   settings, protocol v1, files, ...
    algo/     the paper: networks, DDPG, HER, Eq. 4-6, S-ICM (Eq. 8), Eq. 9's starts
    envs/     the Fetch tasks, the multi-step Push, the simplified state
    stats/    Table I's statistic, trial statistics (numbers, no files)
    runs/     run folders, packed checkpoints, the plan, Table I from the runs
    train/    the policy and its episodes, the trainer (one update, top to bottom)
    deploy/   the export, the perturbations and the robustness tests
    cli/      the commands of `python -m acder_lite`
    book/     what only the book's chapters use

The public names below are imported on first use, so `import acder_lite` stays cheap
(no torch, no MuJoCo) and registers FetchPushMultiStep-v0 with gymnasium.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

__version__ = "0.1.0"

PUBLIC = {
    "Config": "acder_lite.config",
    "METHODS": "acder_lite.config",
    "ENV_IDS": "acder_lite.config",
    "TASK_PRESETS": "acder_lite.config",
    "ConfigError": "acder_lite.config",
    "Trainer": "acder_lite.train.trainer",
    "Policy": "acder_lite.train.rollout",
    "run_episodes": "acder_lite.train.rollout",
    "make_env": "acder_lite.envs.fetch",
    "intrinsic_reward": "acder_lite.algo.rewards",
    "goal_oriented_factor": "acder_lite.algo.rewards",
    "shaped_reward": "acder_lite.algo.rewards",
    "novel_start_ratio": "acder_lite.algo.start_states",
    "sample_her_transitions": "acder_lite.algo.her",
    "DDPG": "acder_lite.algo.ddpg",
    "SICM": "acder_lite.algo.curiosity",
    "ICM": "acder_lite.algo.curiosity",
    "StartStateSelector": "acder_lite.algo.start_states",
}
"""The names a chapter or a user imports from `acder_lite` itself, and the module that
defines each."""

__all__ = sorted(PUBLIC)


def __getattr__(name: str):
    """`acder_lite.Trainer` and the other `PUBLIC` names, imported when first asked for
    (PEP 562)."""
    if name in PUBLIC:
        value = getattr(importlib.import_module(PUBLIC[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'acder_lite' has no attribute {name!r}")


MOVED = {
    "core": "algo.core",
    "compiled": "algo.compiled",
    "ddpg": "algo.ddpg",
    "her": "algo.her",
    "rewards": "algo.rewards",
    "curiosity": "algo.curiosity",
    "start_states": "algo.start_states",
    "normalizer": "algo.normalizer",
    "buffer": "algo.buffer",
    "priority": "algo.priority",
    "multistep": "envs.multistep",
    "observations": "envs.observations",
    "fastobs": "envs.fastobs",
    "report": "stats.report",
    "trial_stats": "stats.trial_stats",
    "runfiles": "runs.runfiles",
    "packed": "runs.packed",
    "plan": "runs.plan",
    "same_as": "runs.same_as",
    "grid_time": "runs.grid_time",
    "table": "runs.table",
    "wraps": "runs.wraps",
    "rollout": "train.rollout",
    "trainer": "train.trainer",
    "perturb": "deploy.perturb",
    "robust": "deploy.robust",
    "export": "deploy.export",
    "stored_bench": "deploy.stored_bench",
    "bench": "cli.bench",
    "diagnose": "cli.diagnose",
    "sweep": "cli.sweep",
    "cluster": "cli.cluster",
    "book_utils": "book.utils",
    "plots": "book.plots",
    "viz": "book.viz",
    "findings": "book.findings",
    "multistep_report": "book.multistep_report",
    "deploy_report": "book.deploy_report",
    "factor_report": "book.factor_report",
    "per_seed": "book.per_seed",
    "novelty": "book.novelty",
    "random_play": "book.random_play",
}
"""Where each module of the flat package (before the layers) lives now: `import
acder_lite.rewards` still works and gives `acder_lite.algo.rewards` itself (the same
module object, so a monkeypatch through either name reaches both). Three old names are
folders now, so they no longer name one module: `acder_lite.envs` (the wrapper is
`acder_lite.envs.fetch`; `make_env` is also `acder_lite.make_env`), `acder_lite.runs`
(reading runs is `acder_lite.runs.read`) and `acder_lite.cli` (the commands are
`acder_lite.cli.main`; `python -m acder_lite` is unchanged). The moves are listed in the
book's "Using acder_lite" page."""


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Resolves `acder_lite.<old name>` (`MOVED`) to the module at its new place."""

    def find_spec(self, fullname, path=None, target=None):
        head, _, tail = fullname.partition(".")
        if head == "acder_lite" and tail in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        # the new module itself, not a copy: sys.modules[old] is sys.modules[new]
        return importlib.import_module(
            "acder_lite." + MOVED[spec.name.split(".", 1)[1]]
        )

    def exec_module(self, module):
        pass  # already executed under its own name


if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
    sys.meta_path.append(_OldPaths())


def _register_envs() -> None:
    """Register the package's own task, FetchPushMultiStep-v0
    (`acder_lite.envs.multistep`), with gymnasium, so `gym.make` finds it once
    acder_lite is imported (idempotent; the env module and gymnasium-robotics are
    imported only when the env is made)."""
    import gymnasium

    if "FetchPushMultiStep-v0" not in gymnasium.registry:
        gymnasium.register(
            id="FetchPushMultiStep-v0",
            entry_point="acder_lite.envs.multistep:MujocoFetchPushMultiStepEnv",
            max_episode_steps=100,
        )


_register_envs()
