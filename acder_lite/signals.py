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


def end_on_signals() -> None:
    """SIGINT and SIGTERM end the process at once (their default action), for a
    command that has returned and is only exiting (`python -m acder_lite`). Trap: a
    second Ctrl-C a moment after the first, once train had said where its checkpoint
    is, raised KeyboardInterrupt inside torch's exit callback (`dump_compile_times`,
    which imports tabulate): "Exception ignored in atexit callback" and a traceback.
    Everything is written by then, and a signal that comes while the handlers change
    asks for the exit already under way: it is dropped."""
    _put_back({signal.SIGINT: signal.SIG_DFL, signal.SIGTERM: signal.SIG_DFL})


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
    this does nothing.

    A second signal during the block is held back too, and the first one is delivered
    (`tests/test_signals.py`). Trap: `signal.signal` first runs the handlers of signals
    that have arrived, then changes its handler; so a Ctrl-C that came once SIGINT's
    handler was back raised in the call that puts SIGTERM's back, which stayed `hold`
    (a later `kill` did nothing) for the rest of the process. Every handler is put back
    now (`_put_back`), whatever a handler raises meanwhile, and the ones to put back
    are read before any is changed."""
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

    old = {s: signal.getsignal(s) for s in kinds}  # before any is changed
    try:
        for s in kinds:  # a signal before the block: its handler raises here
            signal.signal(s, hold)
        yield
    finally:
        late = _put_back(old)
    if caught:
        signal.raise_signal(caught[0])
    if late is not None:  # a signal after the block, as its handler delivered it
        raise late


def _put_back(old: dict) -> BaseException | None:
    """Set each signal's handler in `old` back, every one of them, and return what a
    handler raised meanwhile (None if none did): the handler of a signal that arrived
    once its own was back, which `signal.signal` runs before it changes the next."""
    late, todo = None, list(old.items())
    while todo:
        try:
            while todo:  # trap: a handler may raise at any bytecode, the loop's too
                signal.signal(*todo[0])
                del todo[0]
        except BaseException as e:  # a handler's, e.g. our KeyboardInterrupt
            late = late or e
    return late
