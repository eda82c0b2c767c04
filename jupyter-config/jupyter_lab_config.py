# JupyterLab for the chapters: `make lab` runs
# `jupyter lab --config=jupyter-config/jupyter_lab_config.py` from the project's venv
# (tests/test_browser.py starts the same configuration). It listens on 127.0.0.1 only,
# with a token (random per start, printed in the URL), runs the chapters with the venv's
# Python as the kernel, and makes no network request of its own: no news feed, no update
# check, no extension listing from PyPI.
import os
import sys

c = get_config()  # noqa: F821 (traitlets defines it for a config file)
here = os.path.dirname(os.path.abspath(__file__))

c.ServerApp.ip = "127.0.0.1"
c.ServerApp.allow_remote_access = False
c.ServerApp.root_dir = os.path.dirname(here)  # the repo root
c.LabApp.default_url = "/lab/tree/notebooks"
# No c.IdentityProvider.token: jupyter_server draws a random one at every start (or
# takes JUPYTER_TOKEN).

# The kernel: the venv's own python3 kernelspec ("python" in it is the server's
# sys.executable), found before a python3 kernelspec the user may have in
# ~/.local/share/jupyter.
os.environ["JUPYTER_PREFER_ENV_PATH"] = "1"

# Kernels talk to the server over Unix sockets, not TCP, each under a short name of its
# own (ipc_kernels.py says why: a port race with the Meshcat and Ray servers that the
# chapters start, and the 107-byte limit on a socket's path).
sys.path.insert(0, here)
c.MappingKernelManager.kernel_manager_class = "ipc_kernels.IPCServerKernelManager"

# No network at run time.
c.LabApp.news_url = None
c.LabApp.check_for_updates_class = "jupyterlab.NeverCheckForUpdate"
c.LabApp.extension_manager = "readonly"
# overrides.json: the same, in the front end
c.LabApp.app_settings_dir = os.path.join(here, "settings")
