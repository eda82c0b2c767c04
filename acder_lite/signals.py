"""Stopping a long command cleanly: SIGINT and SIGTERM become KeyboardInterrupt."""


def interrupt_on_signals() -> None:
    """SIGINT and SIGTERM raise KeyboardInterrupt, so `train` stops at once and keeps
    its last checkpoint, and `sweep` cancels its cells (each keeps its own). Trap: a
    process started in the background by a non-interactive shell (`nohup ... &`)
    inherits SIGINT *ignored*, and Python then leaves it ignored, so `kill -INT` would
    do nothing; we install the handler anyway, and SIGTERM (plain `kill`) works the same
    way."""
    import signal

    def handler(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
