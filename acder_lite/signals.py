"""Stopping a long command cleanly: SIGINT and SIGTERM become KeyboardInterrupt."""

import contextlib
import signal
import threading


def interrupt_on_signals() -> None:
    """SIGINT and SIGTERM raise KeyboardInterrupt, so `train` stops at once and keeps
    its last checkpoint, and `sweep` cancels its cells (each keeps its own). Trap: a
    process started in the background by a non-interactive shell (`nohup ... &`)
    inherits SIGINT *ignored*, and Python then leaves it ignored, so `kill -INT` would
    do nothing; we install the handler anyway, and SIGTERM (plain `kill`) works the same
    way."""

    def handler(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)


@contextlib.contextmanager
def deferred():
    """SIGINT and SIGTERM held back while the block runs, and delivered once it has
    ended normally (to the handler that was in place: our KeyboardInterrupt, Python's,
    or the default that ends the process). The files (`io`) are written under it.

    Trap: an interrupt that lands inside `torch.save` comes out of its zip writer as a
    RuntimeError, not a KeyboardInterrupt, so Ctrl-C during a checkpoint's write used to
    end `train` with a traceback and exit 1 instead of the one line and 130 (the old
    checkpoint survived: the write is atomic). Held back, the interrupt arrives a moment
    later, between two files. Only the main thread receives signals in Python; elsewhere
    this does nothing."""
    kinds = (signal.SIGINT, signal.SIGTERM)
    # None: a handler set outside Python, which signal.signal could not put back
    if threading.current_thread() is not threading.main_thread() or any(
        signal.getsignal(s) is None for s in kinds
    ):
        yield
        return
    caught: list[int] = []

    def hold(signum, frame):
        caught.append(signum)

    old = {s: signal.signal(s, hold) for s in kinds}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if caught:
        signal.raise_signal(caught[0])
