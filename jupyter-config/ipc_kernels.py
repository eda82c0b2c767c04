"""Jupyter kernels that talk over Unix sockets, not TCP: `make lab`
(jupyter_lab_config.py), the notebooks under nbmake (notebooks/conftest.py) and `make
book` (this module is also a Sphinx extension: _config.yml's local_extensions) use them.

The trap this avoids: over TCP, jupyter_client picks a free port by binding and closing
it, writes it to the kernel's connection file, and the kernel binds it a moment later.
Another process (another kernel, a Ray or Meshcat server a chapter starts) can take the
port in between; the kernel then dies with `Address already in use` (nbmake reported
"Kernel died before replying to kernel_info" and failed CI once, 03_her). A Unix socket
with a name of its own cannot collide.

Why not just `transport = "ipc"`: jupyter_client then names the sockets after the
connection file, or the relative "kernel-ipc" when asked before that file is named
(nbclient asks): the kernel, started in the notebook's folder, and the client,
elsewhere, would look for different sockets. And a socket's path must fit in 107 bytes,
which a connection file under a deep runtime folder does not (pytest's tmp_path, a long
$HOME). So each kernel gets a short absolute name of its own in the temp folder;
jupyter_client removes the sockets when the kernel stops.

A second trap, on the client's side (nbclient's, for `make book` and nbmake): a zmq
socket wakes asyncio through an edge-triggered file descriptor, and a wake-up can be
lost while the message itself sits in the socket's queue. jupyter_client's
`get_msg(timeout)` then waits out its whole timeout before it looks again and finds the
reply: `make book` stood still for 30 minutes (the chapters' cell timeout) in chapter 4,
the kernel idle after its last cell, the client waiting for that cell's reply; a second
client on the same kernel was answered at once. `SlicedPollChannel` looks at the socket
at least every `POLL_SLICE` seconds, so a lost wake-up costs that much, not the
timeout (tests/test_kernels.py stages a lost wake-up and checks both).
"""

import functools
import os
import tempfile
import time
import uuid
from queue import Empty

from jupyter_client import AsyncKernelClient, AsyncKernelManager
from jupyter_client.channels import AsyncZMQSocketChannel
from jupyter_server.services.kernels.kernelmanager import ServerKernelManager
from traitlets import CaselessStrEnum, Type

POLL_SLICE = 1.0
"""Seconds a client channel waits on its socket's wake-up before it looks again."""


def socket_prefix() -> str:
    """A fresh absolute path for one kernel's sockets (`<prefix>-1`, `-2`, ...)."""
    return os.path.join(tempfile.gettempdir(), f"acder-kernel-{uuid.uuid4().hex}-ipc")


class SlicedPollChannel(AsyncZMQSocketChannel):
    """jupyter_client's async channel, whose `get_msg` polls in slices of
    `POLL_SLICE` seconds up to its timeout (None: for ever): each slice that ends looks
    at the socket itself, so a message whose wake-up was lost is found then."""

    async def get_msg(self, timeout: float | None = None) -> dict:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            step = POLL_SLICE if left is None else min(POLL_SLICE, left)
            if await self.socket.poll(int(step * 1000)):
                return await self._recv()
            if left is not None and left <= POLL_SLICE:
                raise Empty


class IPCKernelClient(AsyncKernelClient):
    """nbclient's kernel client with `SlicedPollChannel` on every zmq channel."""

    shell_channel_class = Type(SlicedPollChannel)
    iopub_channel_class = Type(SlicedPollChannel)
    stdin_channel_class = Type(SlicedPollChannel)
    control_channel_class = Type(SlicedPollChannel)


class IPCKernelManager(AsyncKernelManager):
    """jupyter_client's kernel manager (nbclient's, nbmake's) over Unix sockets; its
    clients (`km.client()`) are `IPCKernelClient`s."""

    transport = CaselessStrEnum(["tcp", "ipc"], default_value="ipc", config=True)
    client_factory = Type(IPCKernelClient)

    def _ip_default(self) -> str:
        return socket_prefix()


class IPCServerKernelManager(ServerKernelManager):
    """jupyter_server's kernel manager (JupyterLab's) over Unix sockets."""

    transport = CaselessStrEnum(["tcp", "ipc"], default_value="ipc", config=True)

    def _ip_default(self) -> str:
        return socket_prefix()


def setup(app):
    """Sphinx extension for `make book`: myst-nb executes each chapter through
    jupyter_cache's `single_nb_execution`, which calls nbclient's `execute` by the
    module-level name `executenb` and offers no option for the kernel manager; give it
    this module's. (The pin of jupyter-cache in requirements.txt keeps the name true;
    the assert makes a version without it fail loudly.)"""
    import jupyter_cache.executors.utils as run
    import nbclient

    assert hasattr(run, "executenb"), "jupyter_cache no longer has executenb"
    run.executenb = functools.partial(
        nbclient.execute, kernel_manager_class=IPCKernelManager
    )
    return {"parallel_read_safe": True, "parallel_write_safe": True}
