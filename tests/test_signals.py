"""Ctrl-C and `kill` while a file is written (signals.deferred, io's atomic writes)."""

import os
import signal
import threading

import pytest
import torch

from acder_lite import io, signals


@pytest.fixture
def handlers():
    """Put the test process's SIGINT and SIGTERM handlers back afterwards."""
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    for s, h in old.items():
        signal.signal(s, h)


class SignalOnWrite:
    """A file whose first `write` sends this process `signum`: the signal lands inside
    torch.save's zip writer, where a KeyboardInterrupt turns into a RuntimeError."""

    def __init__(self, f, signum):
        self.f, self.signum, self.sent = f, signum, False

    def write(self, b):
        if not self.sent:
            self.sent = True
            os.kill(os.getpid(), self.signum)
        return self.f.write(b)

    def __getattr__(self, name):
        return getattr(self.f, name)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_inside_torch_save_arrives_after_the_file(
    tmp_path, handlers, signum
):
    signals.interrupt_on_signals()
    path = tmp_path / "checkpoint.pt"
    state = {"w": torch.arange(50_000.0)}
    with pytest.raises(KeyboardInterrupt):
        io.atomic_write(
            str(path), lambda f: torch.save(state, SignalOnWrite(f, signum))
        )
    assert torch.equal(torch.load(path)["w"], state["w"])  # written whole
    assert os.listdir(tmp_path) == ["checkpoint.pt"]  # no temporary file left


def test_pythons_own_handler_is_deferred_too(tmp_path, handlers):
    signal.signal(signal.SIGINT, signal.default_int_handler)
    path = tmp_path / "x.bin"
    with pytest.raises(KeyboardInterrupt):
        io.atomic_write(
            str(path), lambda f: SignalOnWrite(f, signal.SIGINT).write(b"x")
        )
    assert path.read_bytes() == b"x"
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_no_signal_no_interrupt_and_the_handlers_come_back(tmp_path, handlers):
    signals.interrupt_on_signals()
    before = signal.getsignal(signal.SIGINT)
    io.atomic_write(str(tmp_path / "a"), lambda f: f.write(b"a"))
    assert signal.getsignal(signal.SIGINT) is before


def test_a_write_outside_the_main_thread_works(tmp_path):
    """signal.signal raises ValueError off the main thread: deferred does nothing."""
    errors = []

    def write():
        try:
            io.atomic_write(str(tmp_path / "t"), lambda f: f.write(b"t"))
        except Exception as e:  # pragma: no cover - the failure being tested
            errors.append(e)

    t = threading.Thread(target=write)
    t.start()
    t.join()
    assert not errors and (tmp_path / "t").read_bytes() == b"t"
