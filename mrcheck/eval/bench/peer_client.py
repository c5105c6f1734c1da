"""The bench's side of the peers' line protocol (:mod:`mrcheck.eval.bench.peers`): start a peer's
worker process, wait for its ready line, ask it for timed frames, stop it; every failure is a
:class:`PeerError` with a one-line reason and leaves the worker stopped."""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from mrcheck.eval.bench.peers import (
    FRAME_TIMEOUT_S,
    NOT_INSTALLED,
    PEER_CLASSES,
    START_TIMEOUT_S,
)


class PeerError(RuntimeError):
    """A peer that could not start or stopped answering; the message is its one-line reason."""

    def __init__(self, reason: str):
        super().__init__(" ".join(str(reason).split()))


class PeerNotInstalled(PeerError):
    """A peer whose packages or driver are missing on this machine (its reason begins with
    NOT_INSTALLED), as against one that is installed and fails: a test may skip the first only."""


def failure_reason(exc: BaseException) -> str:
    """The one-line reason a peer gives for any exception from its worker."""
    return str(exc) if isinstance(exc, PeerError) else f"{type(exc).__name__}: {exc}"


def write_mesh(path: Path, vertices, faces, viewpoint: dict, size) -> Path:
    np.savez(
        path,
        vertices=np.asarray(vertices, np.float32),
        faces=np.asarray(faces, np.int32),
        eye=np.asarray(viewpoint["eye"], float),
        target=np.asarray(viewpoint["target"], float),
        up=np.asarray(viewpoint.get("up", (0, 0, 1)), float),
        fov_y_deg=float(viewpoint.get("fov_y_deg", 60.0)),
        size=np.asarray(size, int),
    )
    return path


def importable(peer: str) -> str | None:
    """None when the peer's packages (and for Open3D, a Vulkan driver) are installed, else why
    not, beginning with NOT_INSTALLED (checked without importing them: the worker imports them,
    and reports a failed import as not installed too)."""
    from importlib.util import find_spec

    for package in PEER_CLASSES[peer].packages:
        if find_spec(package) is None:
            hint = "pip install 'mrcheck[bench]' or ./bootstrap.sh bench" if peer == "vtk" else "pip install open3d"
            return f"{NOT_INSTALLED}{package} ({hint})"
    if peer == "open3d" and not _vulkan_driver():
        return (
            f"{NOT_INSTALLED}a Vulkan driver, which Open3D's headless renderer needs "
            "(apt-get install libvulkan1 mesa-vulkan-drivers, or ./bootstrap.sh bench)"
        )
    return None


def _vulkan_driver() -> bool:
    """Whether the Vulkan loader and an installable client driver (an ICD manifest) are there,
    where the loader looks for them on Linux; True elsewhere (not checked)."""
    if not sys.platform.startswith("linux"):
        return True
    import ctypes.util

    if ctypes.util.find_library("vulkan") is None:
        return False
    if os.environ.get("VK_ICD_FILENAMES") or os.environ.get("VK_DRIVER_FILES"):
        return True  # chosen by hand: the loader is told where the driver is
    data_dirs = os.environ.get("XDG_DATA_DIRS") or "/usr/local/share:/usr/share"
    folders = ["/etc/vulkan/icd.d", *(Path(d) / "vulkan" / "icd.d" for d in data_dirs.split(":") if d)]
    return any(Path(folder).is_dir() and any(Path(folder).glob("*.json")) for folder in folders)


class PeerWorker:
    """One peer's worker process. :meth:`start` launches it, :meth:`wait_ready` reads its ready
    line; :meth:`frame` asks for one timed frame. Any failure raises :class:`PeerError` with a
    one-line reason (the tail of the worker's stderr when it died) and leaves the worker stopped."""

    def __init__(self, peer: str, mesh: Path, png: Path, command=None, log: Path | None = None):
        self.peer, self.png = peer, Path(png)
        self.command = command or [
            sys.executable,
            "-m",
            "mrcheck.eval.bench.peers",
            peer,
            "--mesh",
            str(mesh),
            "--png",
            str(png),
        ]
        self.log_path = Path(log) if log else self.png.with_suffix(".log")
        self.info: dict = {}
        self.peak_rss_mb: float | None = None  # the worker's largest peak over the frames it rendered
        self.proc: subprocess.Popen | None = None
        self._buffer = b""

    def start(self) -> "PeerWorker":
        self._log = open(self.log_path, "wb")
        try:
            self.proc = subprocess.Popen(
                self.command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log, close_fds=True
            )
        except OSError as exc:
            self._log.close()
            raise PeerError(f"could not start the {self.peer} worker: {exc}") from exc
        return self

    def wait_ready(self, timeout: float = START_TIMEOUT_S) -> dict:
        message = self._read(timeout, "starting")
        if not message.get("ready"):
            self.stop()
            error = PeerNotInstalled if message.get("not_installed") else PeerError
            raise error(message.get("error") or f"unexpected answer {message}")
        self.info = message
        backend = self._backend()
        if backend:
            message.setdefault("settings", {})["backend"] = backend
        return message

    def _backend(self) -> str | None:
        """The GPU backend the peer's libraries reported on stderr (Filament names its own)."""
        try:
            lines = self.log_path.read_text(errors="replace").splitlines()
        except OSError:
            return None
        keys = ("resolved backend", "device driver")
        found = [" ".join(line.split()) for line in lines if any(k in line for k in keys)]
        return "; ".join(found) or None

    def frame(self, timeout: float = FRAME_TIMEOUT_S) -> float:
        self._write("frame")
        message = self._read(timeout, "rendering a frame")
        if "ms" not in message:
            self.stop()
            raise PeerError(message.get("error") or f"unexpected answer {message}")
        if message.get("peak_rss_mb") is not None:
            self.peak_rss_mb = max(self.peak_rss_mb or 0.0, float(message["peak_rss_mb"]))
        return float(message["ms"])

    def stop(self, timeout: float = 30.0) -> dict:
        """Ask the worker to quit (its summary if it answers), kill it if it does not."""
        summary = {}
        if self.proc is not None and self.proc.poll() is None:
            try:
                self._write("quit")
                summary = self._read(timeout, "quitting")
            except PeerError:
                pass
        self._cleanup(timeout)
        return summary

    def _cleanup(self, timeout: float = 30.0) -> int | None:
        """Wait for (or kill) the worker, close its pipes and log; its exit code. Idempotent."""
        proc, self.proc = self.proc, None
        if proc is None:
            return None
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        for pipe in (proc.stdin, proc.stdout):
            try:
                pipe.close()
            except OSError:
                pass
        self._log.close()
        return proc.returncode

    def _write(self, line: str) -> None:
        if self.proc is None:
            raise PeerError(f"the {self.peer} worker is not running")
        try:
            self.proc.stdin.write(line.encode() + b"\n")
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError) as exc:
            raise self._died(f"{type(exc).__name__} writing to it") from exc

    def _read(self, timeout: float, doing: str) -> dict:
        if self.proc is None:
            raise PeerError(f"the {self.peer} worker is not running")
        deadline = time.monotonic() + timeout
        fd = self.proc.stdout.fileno()
        while b"\n" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                self.proc.kill()
                raise self._died(f"no answer within {timeout:.0f} s while {doing}")
            ready, _, _ = select.select([fd], [], [], left)
            if ready:
                chunk = os.read(fd, 65536)
                if not chunk:
                    raise self._died(f"exited while {doing}")
                self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        try:
            return json.loads(line)
        except ValueError:
            raise self._died(f"answered {line[:80]!r} while {doing}") from None

    def _died(self, what: str) -> PeerError:
        """Stop the worker; the reason names the exit code and the last line of its stderr."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
        code = self._cleanup()
        tail = ""
        try:
            lines = [ln.strip() for ln in self.log_path.read_text(errors="replace").splitlines() if ln.strip()]
            tail = f"; last stderr line: {lines[-1][:200]}" if lines else ""
        except OSError:
            pass
        status = f" (exit code {code})" if code is not None else ""
        return PeerError(f"the {self.peer} worker {what}{status}{tail}")


__all__ = ["PeerError", "PeerNotInstalled", "PeerWorker", "failure_reason", "importable", "write_mesh"]
