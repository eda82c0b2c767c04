"""ACDER Lite: DDPG, HER, S-ICM curiosity, the goal-oriented factor and dynamic start
states (Li et al., "ACDER: Augmented Curiosity-Driven Experience Replay") on the MuJoCo
Fetch tasks."""

__version__ = "0.1.0"


def _register_envs() -> None:
    """Register the package's own task, FetchPushMultiStep-v0 (`acder_lite.multistep`),
    with gymnasium, so `gym.make` finds it once acder_lite is imported (idempotent; the
    env module and gymnasium-robotics are imported only when the env is made)."""
    import gymnasium

    if "FetchPushMultiStep-v0" not in gymnasium.registry:
        gymnasium.register(
            id="FetchPushMultiStep-v0",
            entry_point="acder_lite.multistep:MujocoFetchPushMultiStepEnv",
            max_episode_steps=100,
        )


_register_envs()
