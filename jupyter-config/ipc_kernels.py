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
"""

import functools
import os
import tempfile
import uuid

from jupyter_client import AsyncKernelManager
from jupyter_server.services.kernels.kernelmanager import ServerKernelManager
from traitlets import CaselessStrEnum


def socket_prefix() -> str:
    """A fresh absolute path for one kernel's sockets (`<prefix>-1`, `-2`, ...)."""
    return os.path.join(tempfile.gettempdir(), f"acder-kernel-{uuid.uuid4().hex}-ipc")


class IPCKernelManager(AsyncKernelManager):
    """jupyter_client's kernel manager (nbclient's, nbmake's) over Unix sockets."""

    transport = CaselessStrEnum(["tcp", "ipc"], default_value="ipc", config=True)

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
