"""The peers of ``mrcheck bench``, each in a process of its own.

In the bench's process VTK's EGL window breaks mrcheck's moderngl context, so every peer renders
in a worker subprocess that stays alive and answers a line protocol on stdin/stdout; the bench
times its own frame in turns with one peer frame per request, so the machine's drift falls on
both sides of a ratio alike. ::

    python -m mrcheck.eval.bench.peers {vtk,open3d} --mesh MESH.npz --png FRAME.png [--frames N]

``MESH.npz`` holds ``vertices`` (V, 3) float32, ``faces`` (F, 3) int32, ``eye``, ``target``,
``up``, ``fov_y_deg`` (vertical) and ``size`` (width, height): see :func:`write_mesh`.

The bench's side of the protocol (starting a worker, asking it for frames) is
:mod:`mrcheck.eval.bench.peer_client`.

The worker sets the peer up, renders one frame with the peer's AO off and one with it on (the
warm-up; saved to ``--png``), and prints one JSON line: ``{"ready": true, "peer", "version",
"settings", "png", "ao_effect", "setup_ms", "setup_peak_rss_mb"}`` -- ``ao_effect`` is the mean
difference between the AO-on and AO-off frames in 8-bit levels and the share of pixels the AO
darkened by more than 2 levels, which shows that the AO is really on (the AO-off frame is saved
next to ``--png`` as ``*_ao_off.png``). Then per request line:

* ``frame`` -> ``{"ms": T, "peak_rss_mb": M}``: one frame, render plus read-back of the image
  (the read-back finishes the peer's GPU work), timed inside the worker, and the worker's peak
  resident memory during it (:func:`peak_rss_mb`, reset before the frame where it can be);
* ``quit`` -> ``{"frames": n, "min_ms", "median_ms", "max_ms", "peak_rss_mb"}``, then the worker
  exits.

With ``--frames N`` it times N frames after the warm-up by itself and prints the summary line.
On failure it prints ``{"error": "..."}`` if it still can and exits non-zero; when the peer's
packages cannot be imported, ``{"error": "not installed: ...", "not_installed": true}`` (a peer
that is not installed is not a peer that fails). Everything the peer's libraries print goes to
stderr; stdout carries only the protocol.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import resource
import sys
import time
from pathlib import Path
from statistics import median

import numpy as np

PEERS = ("vtk", "open3d")
VTK_KERNEL = 32  # the setting: enable_ssao(kernel_size=32), no MSAA
GREY = (0.7, 0.7, 0.7)
# A hung peer must not hold the bench up for long (--quick takes a minute or two), and a slow one
# must still be timed. Set-up of the 1.5 M-triangle line mesh plus its two first frames took
# 2-5 s on this project's 2-core machine, busy or not; a frame 0.2-2 s (Open3D's on a busy one).
START_TIMEOUT_S = 120.0  # some 25x the slowest set-up seen
FRAME_TIMEOUT_S = 60.0  # some 30x the slowest frame seen
NOT_INSTALLED = "not installed: "  # how the reason of a peer that is not installed begins


# -- peak memory (the bench's process and the workers alike) -------------------------------------
def reset_peak_rss() -> bool:
    """Lower this process's peak resident memory (VmHWM) to what it holds now, so that the next
    :func:`peak_rss_mb` is the peak since this call (Linux: "5" into /proc/self/clear_refs). It
    lowers what ``ru_maxrss`` reports too. False where it cannot: the peak is then since start."""
    try:
        with open("/proc/self/clear_refs", "w") as clear_refs:
            clear_refs.write("5")
        return True
    except OSError:
        return False


def peak_rss_mb() -> float:
    """This process's peak resident memory in MiB since the last :func:`reset_peak_rss` (VmHWM),
    or since it started (``ru_maxrss``) where /proc/self/status is not there."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0  # kB
    except OSError:
        pass
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 2**20 if sys.platform == "darwin" else rss / 1024.0  # bytes on macOS, KiB on Linux


# -- the peers (run inside the worker) -----------------------------------------------------------
class VtkPeer:
    """VTK's SSAO pass through pyvista: ``enable_ssao(kernel_size=32)`` (radius 0.5, bias 0.005,
    blur on: pyvista's defaults), no MSAA, no FXAA/SSAA, off screen. A frame is ``Render()`` plus
    reading the RGBA buffer back."""

    name = "vtk"
    packages = ("pyvista", "vtk")

    def __init__(self, vertices, faces, view: dict, size):
        if not os.environ.get("DISPLAY"):  # no X server: VTK's wheel renders through EGL
            os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
        import pyvista as pv
        import vtk

        self.size = size
        pv.global_theme.multi_samples = 0
        mesh = pv.PolyData.from_regular_faces(vertices, faces)
        self.plotter = pv.Plotter(off_screen=True, window_size=list(size))
        self.plotter.ren_win.SetMultiSamples(0)
        self.plotter.add_mesh(mesh, color=GREY)
        self.plotter.disable_anti_aliasing()
        self.plotter.camera_position = [tuple(view["eye"]), tuple(view["target"]), tuple(view["up"])]
        self.plotter.camera.view_angle = float(view["fov_y_deg"])  # vertical, like mrcheck's
        self.plotter.renderer.ResetCameraClippingRange()
        self._pixels = vtk.vtkUnsignedCharArray()
        self.version = f"pyvista {pv.__version__}, VTK {vtk.vtkVersion.GetVTKVersion()}"
        self._pv = pv

    def set_ao(self, on: bool) -> None:
        if on:
            self.plotter.enable_ssao(kernel_size=VTK_KERNEL)
        else:
            self.plotter.disable_ssao()

    def settings(self) -> dict:
        ssao = self.plotter.renderer._render_passes._ssao_pass
        window = self.plotter.ren_win
        return {
            "ao": "vtkSSAOPass",
            "kernel_size": ssao.GetKernelSize(),
            "radius": ssao.GetRadius(),
            "bias": ssao.GetBias(),
            "blur": bool(ssao.GetBlur()),
            "msaa_samples": window.GetMultiSamples(),
            "fxaa": bool(self.plotter.renderer.GetUseFXAA()),
            "window": window.GetClassName(),
            "gl_renderer": self._gl_renderer(),
            "lighting": "pyvista's default light kit",
            "material": f"grey {GREY}, flat-interpolated normals off (pyvista default)",
        }

    def _gl_renderer(self):
        try:
            info = self.plotter.ren_win.ReportCapabilities()
            lines = [line for line in info.splitlines() if "OpenGL renderer" in line]
            return lines[0].split(":", 1)[1].strip() if lines else None
        except Exception:  # noqa: BLE001 -- informational only
            return None

    def frame(self) -> np.ndarray:
        w, h = self.size
        self.plotter.ren_win.Render()
        self.plotter.ren_win.GetRGBACharPixelData(0, 0, w - 1, h - 1, 0, self._pixels)
        rgba = np.frombuffer(memoryview(self._pixels), np.uint8).reshape(h, w, 4)
        return rgba[::-1, :, :3].copy()  # bottom-up rows; the VTK array is reused by the next frame


class Open3DPeer:
    """Open3D's Filament renderer (``OffscreenRenderer``; headless it picks Filament's Vulkan
    backend on Mesa's lavapipe) with ``set_ambient_occlusion(True)`` (Filament's SAO with its
    default options, no SSCT), ``defaultLit`` grey material and the scene's default lighting. The
    view's other defaults are switched off to match what mrcheck and the VTK peer render: FXAA
    (``set_antialiasing(False)``), MSAA (``set_sample_count(1)``; Open3D's view asks for 4) and the
    sun's shadow map (``set_shadowing(False)``). A frame is ``render_to_image()`` (render and read
    back)."""

    name = "open3d"
    packages = ("open3d",)

    def __init__(self, vertices, faces, view: dict, size):
        import open3d as o3d
        from open3d.visualization import rendering

        mesh = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(vertices.astype(np.float64)), o3d.utility.Vector3iVector(faces)
        )
        mesh.compute_vertex_normals()
        mesh.paint_uniform_color(GREY)
        self.renderer = rendering.OffscreenRenderer(*size)
        material = rendering.MaterialRecord()
        material.shader = "defaultLit"
        self.renderer.scene.add_geometry("line", mesh, material)
        view_settings = self.renderer.scene.view
        view_settings.set_antialiasing(False)
        view_settings.set_sample_count(1)
        view_settings.set_shadowing(False)
        self.renderer.setup_camera(
            float(view["fov_y_deg"]),
            np.asarray(view["target"], float),
            np.asarray(view["eye"], float),
            np.asarray(view["up"], float),
        )
        self.version = f"Open3D {o3d.__version__} (Filament)"
        self._ao = False

    def set_ao(self, on: bool) -> None:
        self.renderer.scene.view.set_ambient_occlusion(on, ssct_enabled=False)
        self._ao = on

    def settings(self) -> dict:
        return {
            "ao": "Filament's SAO with its default AmbientOcclusionOptions (radius 0.3 m, AO buffer at half "
            "resolution, quality LOW, bilateral low-pass filter)",
            "ambient_occlusion": self._ao,
            "ssct": False,
            "antialiasing": False,
            "msaa_samples": 1,
            "shadows": False,
            "material": f"defaultLit grey {GREY}",
            "lighting": "the OffscreenRenderer scene's default lighting (Filament's post-processing on)",
        }

    def frame(self) -> np.ndarray:
        return np.asarray(self.renderer.render_to_image())[..., :3]


PEER_CLASSES = {"vtk": VtkPeer, "open3d": Open3DPeer}


# -- the worker ----------------------------------------------------------------------------------
def _protocol_stdout():
    """A private copy of stdout for the protocol; fd 1 then points at stderr, so whatever the
    peer's libraries print (Filament prints to stdout) cannot corrupt the protocol."""
    sys.stdout.flush()
    out = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return out


def _flush_c_stdio() -> None:
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):
        pass


def _send(out, message: dict) -> None:
    out.write(json.dumps(message) + "\n")
    out.flush()


def _summary(times: list, peaks: list) -> dict:
    if not times:
        return {"frames": 0}
    return {
        "frames": len(times),
        "min_ms": min(times),
        "median_ms": median(times),
        "max_ms": max(times),
        "peak_rss_mb": max(peaks),
    }


def _save_png(path: str, rgb: np.ndarray) -> None:
    from mrcheck.core.output import write_image

    write_image(path, rgb)


def ao_off_png(png) -> Path:
    """Where the worker saves its AO-off frame, beside ``png``."""
    return Path(png).with_name(Path(png).stem + "_ao_off.png")


def _ao_effect(off: np.ndarray, on: np.ndarray) -> dict:
    diff = off.astype(np.int16).mean(axis=2) - on.astype(np.int16).mean(axis=2)
    return {"mean_abs_levels": float(np.abs(diff).mean()), "darkened_share": float((diff > 2).mean())}


def worker(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m mrcheck.eval.bench.peers")
    parser.add_argument("peer", choices=PEERS)
    parser.add_argument("--mesh", required=True)
    parser.add_argument("--png", required=True)
    parser.add_argument("--frames", type=int, default=0, help="time N frames by itself and exit")
    args = parser.parse_args(argv)
    out = _protocol_stdout()
    start = time.perf_counter()
    try:
        for package in PEER_CLASSES[args.peer].packages:
            importlib.import_module(package)
    except Exception as exc:  # noqa: BLE001 -- ImportError, or OSError for a shared library it lacks
        _send(
            out,
            {
                "error": f"{NOT_INSTALLED}{args.peer} cannot be imported: {type(exc).__name__}: {exc}",
                "not_installed": True,
            },
        )
        return 1
    try:
        data = np.load(args.mesh)
        view = {k: data[k].tolist() for k in ("eye", "target", "up")}
        view["fov_y_deg"] = float(data["fov_y_deg"])
        size = tuple(int(v) for v in data["size"])
        peer = PEER_CLASSES[args.peer](data["vertices"], data["faces"], view, size)
        peer.set_ao(False)
        off = peer.frame()
        peer.set_ao(True)
        on = peer.frame()  # the warm-up of the timed setting
        _save_png(args.png, on)
        png_off = str(ao_off_png(args.png))
        _save_png(png_off, off)
        _flush_c_stdio()  # what the peer's libraries printed, before the parent reads it
        _send(
            out,
            {
                "ready": True,
                "peer": args.peer,
                "version": peer.version,
                "settings": peer.settings(),
                "size": list(size),
                "png": args.png,
                "png_ao_off": png_off,
                "ao_effect": _ao_effect(off, on),
                "setup_ms": (time.perf_counter() - start) * 1000.0,
                "setup_peak_rss_mb": peak_rss_mb(),
            },
        )
    except Exception as exc:  # noqa: BLE001 -- the parent gets the reason as one line
        _send(out, {"error": f"{type(exc).__name__}: {exc}"})
        return 1
    times, peaks = [], []
    if args.frames:
        for _ in range(args.frames):
            times.append(_timed(peer))
            peaks.append(peak_rss_mb())
        _send(out, _summary(times, peaks))
        _exit_now()
    for line in sys.stdin:
        command = line.strip()
        if command == "frame":
            times.append(_timed(peer))
            peaks.append(peak_rss_mb())
            _send(out, {"ms": times[-1], "peak_rss_mb": peaks[-1]})
        elif command == "quit":
            break
        elif command:
            _send(out, {"error": f"unknown request {command!r}"})
    _send(out, _summary(times, peaks))
    _exit_now()


def _exit_now() -> None:
    """Exit without tearing the renderer down: the PNGs are written and the summary sent, and
    Filament's Vulkan teardown on lavapipe sometimes hangs (seen: a test waiting 60 s for the
    worker to end), which the parent would otherwise wait out before killing it."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _timed(peer) -> float:
    reset_peak_rss()  # the peak of this frame, as the bench measures its own per entry
    start = time.perf_counter()
    peer.frame()
    return (time.perf_counter() - start) * 1000.0


if __name__ == "__main__":
    sys.exit(worker())
