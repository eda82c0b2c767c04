"""The chapters' kernel clients (jupyter-config/ipc_kernels.py): a reply whose wake-up
was lost is found within a slice, not after the whole timeout."""

import asyncio
import sys
import time
import uuid
from pathlib import Path
from queue import Empty

import pytest
import zmq
import zmq.asyncio
from jupyter_client.channels import AsyncZMQSocketChannel
from jupyter_client.session import Session

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "jupyter-config"))
import ipc_kernels  # noqa: E402


async def reply_with_lost_wakeup(channel_class, wait: float) -> dict | None:
    """A kernel's ROUTER answers a client's DEALER while the client's `get_msg(30)` is
    waiting; before the client's event loop runs again, a read of the socket's EVENTS
    drains its edge-triggered descriptor (the lost wake-up). Returns the message if
    `get_msg` gives it within `wait` seconds, else None."""
    addr = f"ipc://{ipc_kernels.socket_prefix()}-{uuid.uuid4().hex[:6]}"
    router = zmq.Context.instance().socket(zmq.ROUTER)
    router.bind(addr)
    dealer = zmq.asyncio.Context.instance().socket(zmq.DEALER)
    dealer.connect(addr)
    session = Session(key=b"")
    try:
        channel = channel_class(dealer, session)
        await dealer.send(b"hello")
        ident, _ = router.recv_multipart()
        task = asyncio.ensure_future(channel.get_msg(timeout=30))
        await asyncio.sleep(0.05)  # the client waits on its socket
        session.send(router, "execute_reply", {"status": "ok"}, ident=ident)
        time.sleep(0.3)  # the reply arrives; the loop does not run meanwhile
        assert zmq.Socket.shadow(dealer.underlying).get(zmq.EVENTS) & zmq.POLLIN
        try:
            return await asyncio.wait_for(task, wait)
        except asyncio.TimeoutError:
            return None
    finally:
        dealer.close(linger=0)
        router.close(linger=0)
        Path(addr.removeprefix("ipc://")).unlink(missing_ok=True)


def test_jupyter_clients_channel_waits_out_its_timeout_after_a_lost_wakeup():
    """The trap: the reply is in the queue, and the stock channel does not see it."""
    got = asyncio.run(reply_with_lost_wakeup(AsyncZMQSocketChannel, wait=1.5))
    assert got is None


def test_sliced_channel_finds_the_reply_within_a_slice(monkeypatch):
    monkeypatch.setattr(ipc_kernels, "POLL_SLICE", 0.1)
    got = asyncio.run(reply_with_lost_wakeup(ipc_kernels.SlicedPollChannel, wait=10))
    assert got is not None and got["msg_type"] == "execute_reply"
    assert got["content"] == {"status": "ok"}


def test_sliced_channel_still_times_out(monkeypatch):
    """No message: Empty after the timeout, as jupyter_client's own channel."""
    monkeypatch.setattr(ipc_kernels, "POLL_SLICE", 0.1)

    async def wait_for_nothing():
        sock = zmq.asyncio.Context.instance().socket(zmq.DEALER)
        sock.connect(f"ipc://{ipc_kernels.socket_prefix()}-none")
        try:
            t0 = time.monotonic()
            with pytest.raises(Empty):
                await ipc_kernels.SlicedPollChannel(sock, Session()).get_msg(0.35)
            return time.monotonic() - t0
        finally:
            sock.close(linger=0)

    assert asyncio.run(wait_for_nothing()) >= 0.3


def test_the_kernel_managers_clients_use_the_sliced_channel():
    client = ipc_kernels.IPCKernelManager().client()
    for name in ("shell", "iopub", "stdin", "control"):
        assert getattr(client, f"{name}_channel_class") is ipc_kernels.SlicedPollChannel
