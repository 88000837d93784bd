"""Start and stop a private JupyterLab on loopback for `make browser` (tests/browser/run_lab.py).

The server runs from the project venv on 127.0.0.1 (a free port, a random token, no browser,
root = the repository) with its own temporary Jupyter config, data, runtime, settings and
workspace folders (autosave off, so the notebooks on disk are never written; the checkpoints
JupyterLab makes on opening a file go to that temporary folder too). Stopping it
also ends its kernels, which run in sessions of their own.
"""

from __future__ import annotations

import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
LAB_SETTINGS = {  # user settings of this run only (a temporary JUPYTERLAB_SETTINGS_DIR)
    "@jupyterlab/docmanager-extension/plugin": {"autosave": False},
    "@jupyterlab/apputils-extension/notification": {"fetchNews": "false",
                                                     "checkForUpdates": False},
}


class SetupError(Exception):
    """JupyterLab or Chromium could not be started (exit status 2)."""


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


RUNNING: list = []  # the labs started and not yet stopped (for the timeout's last resort)


@dataclass
class Lab:
    """A running JupyterLab: its process, address, token and private folders."""

    process: subprocess.Popen
    port: int
    token: str
    home: Path
    log_path: Path

    @property
    def base(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def api(self, path: str, method: str = "GET", timeout: float = 10.0):
        """Call the server's REST API; returns the decoded JSON (None for an empty reply)."""
        request = urllib.request.Request(f"{self.base}{path}", method=method,
                                         headers={"Authorization": f"token {self.token}"})
        with urllib.request.urlopen(request, timeout=timeout) as reply:
            body = reply.read()
        return json.loads(body) if body else None


def lab_environment(home: Path, quick: bool) -> dict:
    """The environment of JupyterLab and its kernels: private Jupyter folders, the venv
    first on PATH, E2V_QUICK as asked and no PYVISTA_JUPYTER_BACKEND (pyvista's JupyterLab
    default, the interactive trame viewer)."""
    env = dict(os.environ)
    for name in ("PYVISTA_JUPYTER_BACKEND", "E2V_QUICK", "JUPYTER_PATH", "MPLBACKEND",
                 "JUPYTERHUB_SERVICE_PREFIX", "PYVISTA_TRAME_SERVER_PROXY_PREFIX",
                 "PYVISTA_OFF_SCREEN"):
        env.pop(name, None)
    if quick:
        env["E2V_QUICK"] = "1"
    for name, sub in (("JUPYTER_CONFIG_DIR", "config"), ("JUPYTER_DATA_DIR", "data"),
                      ("JUPYTER_RUNTIME_DIR", "runtime"), ("JUPYTERLAB_SETTINGS_DIR", "settings"),
                      ("JUPYTERLAB_WORKSPACES_DIR", "workspaces"), ("IPYTHONDIR", "ipython")):
        (home / sub).mkdir(parents=True, exist_ok=True)
        env[name] = str(home / sub)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONUNBUFFERED"] = "1"
    for plugin, values in LAB_SETTINGS.items():
        path = home / "settings" / f"{plugin}.jupyterlab-settings"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(values))
    return env


def pids_with(marker: str, also: str = "") -> list[int]:
    """Process ids whose command line contains ``marker`` (and ``also``): this run's kernels
    (their connection files lie in our runtime folder) and browser (our user-data folder)."""
    pids = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit() or int(proc.name) == os.getpid():
            continue
        try:
            cmdline = (proc / "cmdline").read_bytes().decode(errors="replace")
        except OSError:
            continue
        if marker in cmdline and also in cmdline:
            pids.append(int(proc.name))
    return pids


def kill_group(pid: int, grace: float = 5.0) -> None:
    """SIGTERM the process group led by ``pid`` (or the process alone when it leads none),
    then SIGKILL after ``grace`` seconds if it is still there."""

    def send(sig) -> bool:
        try:
            os.killpg(pid, sig)
            return True
        except ProcessLookupError:
            try:
                os.kill(pid, sig)
                return True
            except ProcessLookupError:
                return False

    if not send(signal.SIGTERM):
        return
    end = time.monotonic() + grace
    while time.monotonic() < end:
        if not send(0):
            return
        time.sleep(0.2)
    send(signal.SIGKILL)


def stop_lab(lab: Lab) -> None:
    """Shut down the kernels and JupyterLab: politely through the API, then by signal."""
    runtime = str(lab.home / "runtime")
    kernels = pids_with(runtime, "ipykernel")
    if lab.process.poll() is None:
        try:
            lab.api("/api/shutdown", method="POST", timeout=5)
            lab.process.wait(timeout=15)
        except (OSError, urllib.error.URLError, subprocess.TimeoutExpired):
            pass
    if lab.process.poll() is None:
        kill_group(lab.process.pid)
    else:  # the server is gone; anything left in its group goes too
        with suppress(ProcessLookupError):
            os.killpg(lab.process.pid, signal.SIGKILL)
    for pid in set(kernels) | set(pids_with(runtime, "ipykernel")):  # in sessions of their own
        kill_group(pid)
    try:
        lab.process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        pass


@contextmanager
def running_lab(home: Path, log_path: Path, quick: bool, timeout: float = 120.0,
                root: Path = REPO):
    """Start JupyterLab on 127.0.0.1 (files from ``root``) and yield a :class:`Lab` once its
    API answers."""
    port, token = free_port(), secrets.token_hex(24)
    jupyter = Path(sys.executable).parent / "jupyter"
    if not jupyter.exists():
        raise SetupError(f"{jupyter} is missing; run `make venv` first")
    command = [str(jupyter), "lab", "--no-browser", "--ServerApp.ip=127.0.0.1",
               f"--ServerApp.port={port}", "--ServerApp.port_retries=0",
               f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={root}",
               # an absolute checkpoint_dir: the checkpoints go there, not into notebooks/
               f"--FileCheckpoints.checkpoint_dir={home / 'checkpoints'}",
               "--LabApp.expose_app_in_browser=True", "--LabApp.news_url=None",
               "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
               "--LabApp.extension_manager=readonly", "--ServerApp.open_browser=False"]
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # CI containers run as root
        command.append("--allow-root")
    log = log_path.open("w")
    process = subprocess.Popen(command, cwd=REPO, env=lab_environment(home, quick), stdout=log,
                               stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                               start_new_session=True)
    lab = Lab(process, port, token, home, log_path)
    RUNNING.append(lab)
    try:
        end = time.monotonic() + timeout
        while True:
            if process.poll() is not None:
                raise SetupError(f"JupyterLab exited with status {process.returncode}; "
                                 f"see {log_path}")
            try:
                lab.api("/api/status", timeout=2)
                break
            except (OSError, urllib.error.URLError):
                if time.monotonic() > end:
                    raise SetupError(f"JupyterLab did not answer on port {port} within "
                                     f"{timeout:.0f} s; see {log_path}") from None
                time.sleep(0.5)
        yield lab
    finally:
        stop_lab(lab)
        RUNNING.remove(lab)
        log.close()
