"""The notebooks under nbmake (`make test`): kernels talk over IPC sockets, not TCP.

The trap this avoids: with two xdist workers, jupyter_client picks a free TCP port by
binding and closing it, writes it to the kernel's connection file, and the kernel binds
it a moment later. Another process (the other worker's kernel, a Ray or Meshcat server)
can take the port in between; the kernel then dies with `Address already in use` and
nbmake reports "Kernel died before replying to kernel_info" (it failed CI once, 03_her).
A Unix socket with a name of its own cannot collide.
"""

import functools
import os
import tempfile
import uuid

import nbclient
import nbmake.nb_run
from jupyter_client import AsyncKernelManager
from traitlets import CaselessStrEnum


class IPCKernelManager(AsyncKernelManager):
    """jupyter_client's kernel manager with `transport = "ipc"` as its default."""

    transport = CaselessStrEnum(["tcp", "ipc"], default_value="ipc", config=True)

    def _ip_default(self) -> str:
        # jupyter_client's default is the relative "kernel-ipc" when asked before
        # the connection file is named (it is): the kernel, started in the notebook's
        # folder, and this client, in the repository's, would look for different
        # sockets. An absolute path, one per kernel, in the temp folder (a socket
        # path must fit in 107 bytes, which a deep $HOME might not); jupyter_client
        # removes the sockets when the kernel stops.
        return os.path.join(
            tempfile.gettempdir(), f"acder-kernel-{uuid.uuid4().hex}-ipc"
        )


# nbmake 1.5.5 builds its NotebookClient by this module-level name and offers no option
# for the kernel manager; the pin in requirements.txt keeps this line true, and the
# assert makes an nbmake without that name fail loudly instead of racing again.
assert hasattr(nbmake.nb_run, "NotebookClient"), "nbmake no longer has NotebookClient"
nbmake.nb_run.NotebookClient = functools.partial(
    nbclient.NotebookClient, kernel_manager_class=IPCKernelManager
)
