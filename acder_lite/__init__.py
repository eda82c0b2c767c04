"""ACDER Lite: DDPG, HER, S-ICM curiosity, the goal-oriented factor and dynamic start states
(Li et al., "ACDER: Augmented Curiosity-Driven Experience Replay") on the MuJoCo Fetch tasks."""
__version__ = "0.1.0"
