"""The notebooks under nbmake (`make test`): kernels talk over Unix sockets, not TCP.

With two xdist workers a kernel's TCP port could be taken between jupyter_client picking
it and the kernel binding it, and nbmake reported "Kernel died before replying to
kernel_info" (it failed CI once, 03_her). `make lab` uses the same kernels;
jupyter-config/ipc_kernels.py has the whole story.
"""

import functools
import sys
from pathlib import Path

import nbclient
import nbmake.nb_run

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "jupyter-config"))
from ipc_kernels import IPCKernelManager  # noqa: E402

# nbmake 1.5.5 builds its NotebookClient by this module-level name and offers no option
# for the kernel manager; the pin in requirements.txt keeps this line true, and the
# assert makes an nbmake without that name fail loudly instead of racing again.
assert hasattr(nbmake.nb_run, "NotebookClient"), "nbmake no longer has NotebookClient"
nbmake.nb_run.NotebookClient = functools.partial(
    nbclient.NotebookClient, kernel_manager_class=IPCKernelManager
)
