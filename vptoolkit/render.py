"""Shaded pictures of meshes, seen through the measures' own camera.

A picture for view direction ``v`` shows what the measures scored for ``v``:
the eye, target and field of view are those of
:class:`vptoolkit.camera.Camera` (``Camera().poses(v, centre=, diagonal=,
resolution=size)`` with the bounding frame of
:func:`vptoolkit.geometry.bounding_frame`). Back faces are culled when the
camera culls them (the default), exactly as the measures do, so a face the
measures counted as invisible is missing from the picture too.

Only the roll differs: the measures keep the authors' image up ``-y``, which
shows the usual ``+y``-up model (glTF, OBJ, PLY scans) upside down, so a
picture's image up is ``RenderStyle.up`` (default ``+y``; ``(0, 0, 1)`` for
ModelNet-style ``+z``-up models). The roll does not change what is seen:
the camera's distance keeps the model's bounding sphere inside the circle
inscribed in the image. With ``RenderStyle(up=Camera().up)`` pixel ``(x,
y)`` of a picture ``size`` pixels wide is pixel ``(x, y)`` of the measures'
triangle-ID image at resolution ``size``.

Shading
    Open3D's ``defaultLit`` material in one flat colour over a plain
    background; normals are smoothed across edges sharper than
    ``crease_angle_deg`` only, so a cube shows flat faces and a scanned
    bunny a smooth surface. One directional light (the sun) shines from
    above and to the left of the camera, so faces that meet at a corner get
    different brightness; Open3D's image-based light adds a soft ambient
    term. Shadows and post-processing are off (Filament's tone mapping would
    tint the background); the image is converted to sRGB here.

The child process
    Open3D 0.20 renders through Vulkan (Filament). Without a Vulkan driver
    Filament aborts the whole process (SIGABRT), and with Mesa's software
    driver (llvmpipe) a frame now and then never finishes. So the renderer
    never runs in the calling process: :class:`Renderer` starts one child
    Python process (``python -c "from vptoolkit.render import _serve;
    _serve()"``) and talks to it over its standard input and output
    (length-prefixed JSON headers and raw little-endian arrays, no pickle).
    The child renders a warm-up frame before it reports ready. If it dies
    before that, :class:`~vptoolkit.errors.MissingDependencyError` says so in
    one line (``renderer: Open3D's offscreen renderer could not start (no
    Vulkan driver?): ...``). A frame that takes longer than
    ``frame_timeout`` seconds, or a child that dies during a frame, is
    retried in a fresh child up to ``attempts`` times in all, then raises
    :class:`~vptoolkit.errors.MeasurementError` naming the mesh; the
    renderer stays usable for the next mesh. One child serves any number of
    frames, so a batch pays the start-up (about 1-3 s) once.

Open3D is imported only in the child; this module itself needs numpy alone.

Engines
    :class:`Renderer` is the ``"open3d"`` engine. On Mesa's software Vulkan
    driver its frame time depends on the view, from 0.1 s to minutes, so
    the functions here and ``vptool`` default to the ``"software"`` engine,
    :class:`vptoolkit.software_render.SoftwareRenderer` (the measures'
    rasteriser and numpy shading, same camera and style);
    :func:`open_renderer` makes either.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import as_path, check_int, check_suffix, one_line
from vptoolkit.conventions import MEASURES, N_VIEWS, RESOLUTION, measure_index
from vptoolkit.errors import InputError, MeasurementError, MissingDependencyError
from vptoolkit.files import write_bytes_atomic
from vptoolkit.geometry import bounding_frame
from vptoolkit.measures import ViewQuality
from vptoolkit.mesh import Mesh
from vptoolkit.shading import (
    RenderStyle,
    crease_normals,
    light_direction,
    linear_to_srgb,
    picture_camera,
    srgb_to_linear,
)
from vptoolkit.sphere import as_directions

__all__ = [
    "RenderStyle",
    "Renderer",
    "RenderedView",
    "DirectionSource",
    "render_view",
    "render_views",
    "render_best",
    "render_predicted",
    "resolve_direction",
    "check_renderer",
    "ENGINES",
    "open_renderer",
    "png_bytes",
    "save_png",
]

DirectionSource = Callable[[Mesh], ArrayLike] | ArrayLike
"""A view direction for a mesh: ``(3,)`` or ``(4, 3)`` (one per measure, in
``MEASURES`` order), or a callable returning either from a
:class:`~vptoolkit.mesh.Mesh` (e.g. a trained network's prediction)."""

_START_TIMEOUT = 120.0  # seconds for the child to import Open3D and create the renderer
_FRAME_TIMEOUT = 15.0  # seconds for one frame (a 512 x 512 frame takes about 0.25 s)
_ATTEMPTS = 3  # tries per frame: hung or dead children are replaced
_QUIT_TIMEOUT = 5.0  # seconds the child gets to exit before it is killed
_STDERR_TAIL = 4000  # bytes of the child's stderr kept for error messages
_CHILD_CODE = "from vptoolkit.render import _serve; _serve()"
_HEADER = struct.Struct("<I")  # byte length of a message's JSON header
_PAYLOAD = struct.Struct("<Q")  # byte length of a message's payload


@dataclass(frozen=True, eq=False)
class RenderedView:
    """A picture and the direction it was taken from.

    Attributes
    ----------
    image : (size, size, 3) uint8
        sRGB picture, row 0 at the top.
    direction : (3,) float64
        Unit view direction from the model centre towards the camera.
    label : str
        What chose the direction, e.g. ``"best VE (view 17)"``, ``"model VE"``.
    """

    image: NDArray[np.uint8]
    direction: NDArray[np.float64]
    label: str


# --------------------------------------------------------------------------- geometry


@dataclass(frozen=True)
class _Frame:
    """Everything the child needs for one picture (computed here, not in the child)."""

    eye: NDArray[np.float64]
    centre: NDArray[np.float64]
    up: NDArray[np.float64]
    light: NDArray[np.float64]  # direction the light travels
    near: float
    far: float


def _frame(camera: Camera, style: RenderStyle, direction: NDArray[np.float64],
           centre: NDArray[np.float64], diagonal: float, size: int) -> _Frame:
    poses = picture_camera(camera, style.up).poses(direction[None, :], centre=centre,
                                                   diagonal=diagonal, resolution=size)
    eye, right, up, forward = poses.eyes[0], poses.right[0], poses.up[0], poses.forward[0]
    distance = camera.distance_factor * diagonal
    radius = diagonal / 2.0
    near = max(distance - 1.05 * radius, 1e-3 * distance)
    far = distance + 1.05 * radius
    return _Frame(eye, centre, up, light_direction(style, forward, up, right), near, far)



# --------------------------------------------------------------------------- messages


def _write_message(stream: IO[bytes], header: dict[str, Any],
                   arrays: dict[str, NDArray[Any]] | None = None) -> None:
    """Send a JSON header and named arrays (little-endian bytes, shapes in the header)."""
    blobs = []
    described = []
    for name, array in (arrays or {}).items():
        contiguous = np.ascontiguousarray(array)
        little = contiguous.astype(contiguous.dtype.newbyteorder("<"), copy=False)
        described.append([name, little.dtype.str, list(little.shape)])
        blobs.append(little.tobytes())
    encoded = json.dumps({**header, "arrays": described}).encode()
    payload = b"".join(blobs)
    stream.write(_HEADER.pack(len(encoded)) + encoded + _PAYLOAD.pack(len(payload)))
    stream.write(payload)
    stream.flush()


def _read_exactly(stream: IO[bytes], n_bytes: int) -> bytes:
    chunks = []
    remaining = n_bytes
    while remaining:
        chunk = stream.read(remaining)
        if not chunk:
            raise EOFError("stream closed")
        chunks.append(chunk)
        remaining -= len(chunk)
    return b"".join(chunks)


def _read_message(stream: IO[bytes]) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    (header_bytes,) = _HEADER.unpack(_read_exactly(stream, _HEADER.size))
    header = json.loads(_read_exactly(stream, header_bytes))
    (payload_bytes,) = _PAYLOAD.unpack(_read_exactly(stream, _PAYLOAD.size))
    payload = _read_exactly(stream, payload_bytes)
    arrays = {}
    offset = 0
    for name, dtype, shape in header.pop("arrays", []):
        kind = np.dtype(dtype)
        count = int(np.prod(shape, dtype=np.int64))
        arrays[name] = np.frombuffer(payload, dtype=kind, count=count, offset=offset).reshape(shape)
        offset += count * kind.itemsize
    return header, arrays


# --------------------------------------------------------------------------- the child


def _serve() -> None:
    """Main loop of the render child process (not part of the public API).

    Protocol: the parent sends ``start`` (size, style), then any number of
    ``mesh`` (corner positions and normals) and ``frame`` (camera, light
    and the faces to draw) messages, then ``quit``. Every message is
    answered with ``{"ok": true, ...}`` or ``{"ok": false, "error": ...}``;
    ``start`` is answered twice, once the renderer exists and once a
    warm-up frame is done.
    """
    protocol_in = os.fdopen(os.dup(0), "rb")
    protocol_out = os.fdopen(os.dup(1), "wb")
    # Filament writes to the C-level stdout; keep it off the protocol pipe.
    quiet = os.open(os.devnull, os.O_RDWR)
    os.dup2(quiet, 0)
    os.dup2(2, 1)
    try:
        header, _ = _read_message(protocol_in)
        size = int(header["size"])
        style = RenderStyle(**{k: tuple(v) if isinstance(v, list) else v
                               for k, v in header["style"].items()})
        try:
            from vptoolkit.optional import require

            o3d = require("open3d")
        except MissingDependencyError as err:
            _write_message(protocol_out, {"ok": False, "error": str(err), "missing": True})
            return
        session = _ChildRenderer(o3d, size, style)
        _write_message(protocol_out, {"ok": True, "stage": "created", "open3d": o3d.__version__})
        session.warm_up()
        _write_message(protocol_out, {"ok": True, "stage": "ready"})
        while True:
            header, arrays = _read_message(protocol_in)
            operation = header["op"]
            if operation == "quit":
                _write_message(protocol_out, {"ok": True})
                break
            try:
                if operation == "mesh":
                    session.set_mesh(arrays["positions"], arrays["normals"])
                    _write_message(protocol_out, {"ok": True})
                elif operation == "frame":
                    image = session.render(header, arrays["faces"])
                    _write_message(protocol_out, {"ok": True}, {"image": image})
                else:
                    _write_message(protocol_out,
                                   {"ok": False, "error": f"unknown op {operation!r}"})
            except (RuntimeError, ValueError, KeyError) as err:
                _write_message(protocol_out, {"ok": False, "error": one_line(err)})
    except EOFError:
        pass  # the parent went away
    finally:
        protocol_out.flush()
        sys.stderr.flush()
        # Filament's shutdown can hang; the parent has what it needs.
        os._exit(0)



class _ChildRenderer:
    """The Open3D side, living in the child process only."""

    def __init__(self, o3d: Any, size: int, style: RenderStyle) -> None:
        self.o3d = o3d
        rendering = o3d.visualization.rendering
        o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
        self.renderer = rendering.OffscreenRenderer(size, size)
        self.size = size
        self.style = style
        scene = self.renderer.scene
        view = scene.view
        view.set_post_processing(False)
        view.set_shadowing(False, rendering.View.ShadowType.PCF)
        scene.show_skybox(False)
        scene.set_background([*style.background, 1.0])
        scene.scene.set_indirect_light_intensity(style.ambient_intensity)
        scene.scene.enable_sun_light(True)
        self.material = rendering.MaterialRecord()
        self.material.shader = "defaultLit"
        self.material.base_color = [*(srgb_to_linear(c) for c in style.color), 1.0]
        self.material.base_roughness = 0.7
        self.material.base_reflectance = 0.3
        self.positions: Any = None
        self.normals: Any = None
        self.has_geometry = False
        self.to_srgb = linear_to_srgb(np.arange(256) / 255.0)  # 8-bit linear -> sRGB

    def warm_up(self) -> None:
        box = self.o3d.geometry.TriangleMesh.create_box()
        box.compute_vertex_normals()
        self.renderer.scene.add_geometry("warm-up", box, self.material)
        self.renderer.setup_camera(45.0, [0.5, 0.5, 0.5], [2.5, 2.0, 3.0], [0.0, 1.0, 0.0],
                                   0.1, 10.0)
        np.asarray(self.renderer.render_to_image())
        self.renderer.scene.remove_geometry("warm-up")

    def set_mesh(self, positions: NDArray[np.float32], normals: NDArray[np.float32]) -> None:
        self.positions = positions
        self.normals = normals

    def render(self, header: dict[str, Any], faces: NDArray[np.int64]) -> NDArray[np.uint8]:
        if self.positions is None:
            raise ValueError("frame before mesh")
        o3d = self.o3d
        corners = (3 * faces.astype(np.int64)[:, None] + np.arange(3)[None, :]).reshape(-1)
        geometry = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(self.positions[corners].astype(np.float64)),
            o3d.utility.Vector3iVector(np.arange(len(corners), dtype=np.int32).reshape(-1, 3)),
        )
        geometry.vertex_normals = o3d.utility.Vector3dVector(
            self.normals[corners].astype(np.float64)
        )
        scene = self.renderer.scene
        if self.has_geometry:
            scene.remove_geometry("model")
            self.has_geometry = False
        if len(faces):
            scene.add_geometry("model", geometry, self.material)
            self.has_geometry = True
        scene.scene.set_sun_light(
            np.asarray(header["light"], dtype=np.float32), np.ones(3, np.float32),
            float(self.style.light_intensity),
        )
        self.renderer.setup_camera(
            float(header["fov_deg"]),
            np.asarray(header["centre"], dtype=np.float32),
            np.asarray(header["eye"], dtype=np.float32),
            np.asarray(header["up"], dtype=np.float32),
            float(header["near"]),
            float(header["far"]),
        )
        linear = np.asarray(self.renderer.render_to_image())[:, :, :3]
        return np.ascontiguousarray(self.to_srgb[linear])


# --------------------------------------------------------------------------- the parent


class _ChildDied(Exception):
    """The child exited or closed its pipe (internal)."""


class _ChildTimedOut(Exception):
    """The child did not answer in time (internal)."""


def _signal_name(returncode: int | None) -> str:
    if returncode is None:
        return "still running"
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    return f"exit status {returncode}"


class _Child:
    """One render child process and the thread that reads its answers."""

    def __init__(self, size: int, style: RenderStyle) -> None:
        self.stderr = tempfile.TemporaryFile()
        environment = dict(os.environ)
        package_root = str(Path(__file__).resolve().parent.parent)
        environment["PYTHONPATH"] = os.pathsep.join(
            [package_root, *filter(None, [environment.get("PYTHONPATH")])]
        )
        self.process = subprocess.Popen(
            [sys.executable, "-c", _CHILD_CODE],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.stderr,
            env=environment,
        )
        self.answers: queue.Queue[tuple[dict[str, Any], dict[str, NDArray[Any]]] | None] = (
            queue.Queue()
        )
        self.reader = threading.Thread(target=self._read_answers, daemon=True)
        self.reader.start()
        self.mesh_key: int | None = None
        self.send({"op": "start", "size": size, "style": style.to_dict()})

    def _read_answers(self) -> None:
        stream = self.process.stdout
        assert stream is not None  # noqa: S101 (set by Popen)
        try:
            while True:
                self.answers.put(_read_message(stream))
        except (EOFError, OSError, ValueError):
            self.answers.put(None)

    def send(self, header: dict[str, Any], arrays: dict[str, NDArray[Any]] | None = None) -> None:
        stream = self.process.stdin
        assert stream is not None  # noqa: S101 (set by Popen)
        try:
            _write_message(stream, header, arrays)
        except (BrokenPipeError, OSError) as err:
            raise _ChildDied(str(err)) from err

    def receive(self, timeout: float) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        try:
            answer = self.answers.get(timeout=timeout)
        except queue.Empty as err:
            raise _ChildTimedOut(f"no answer within {timeout:g} s") from err
        if answer is None:
            try:
                self.process.wait(timeout=_QUIT_TIMEOUT)
            except subprocess.TimeoutExpired:
                pass
            raise _ChildDied(_signal_name(self.process.poll()))
        return answer

    def stderr_reason(self) -> str:
        """The most telling line the child wrote to stderr (Filament's ``reason:``)."""
        try:
            self.stderr.seek(0, os.SEEK_END)
            length = self.stderr.tell()
            self.stderr.seek(max(0, length - _STDERR_TAIL))
            text = self.stderr.read().decode("utf-8", "replace")
        except (OSError, ValueError):
            return ""
        lines = [line.strip() for line in text.splitlines() if line.strip()]
        for line in reversed(lines):
            if line.startswith("reason:"):
                return line
        errors = [line for line in lines if "rror" in line or "panic" in line.lower()]
        return (errors or lines or [""])[-1]

    def close(self, *, is_polite: bool = True) -> None:
        if self.process.poll() is None and is_polite:
            try:
                self.send({"op": "quit"})
                self.process.wait(timeout=_QUIT_TIMEOUT)
            except (_ChildDied, subprocess.TimeoutExpired):
                pass
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        for stream in (self.process.stdin, self.process.stdout):
            if stream is not None:
                try:
                    stream.close()
                except OSError:
                    pass
        self.reader.join(timeout=_QUIT_TIMEOUT)
        self.stderr.close()


class Renderer:
    """A render child process that draws meshes from view directions.

    Use it as a context manager; it starts its child on first use (or on
    :meth:`start`) and stops it on :meth:`close`. All pictures share one
    size. Frames of the same :class:`~vptoolkit.mesh.Mesh` object reuse the
    geometry already sent to the child.

    Parameters
    ----------
    size : int
        Side of the square pictures in pixels, 16 to 4096 (default: 512).
    camera : Camera, optional
        Camera conventions (default: ``Camera()``, those of the measures).
    style : RenderStyle, optional
        Shading (default: ``RenderStyle()``).
    start_timeout : float
        Seconds the child may take for each stage of its start: importing
        Open3D and creating its renderer, then drawing a warm-up frame
        (default: 120).
    frame_timeout : float
        Seconds one frame may take before the child is taken for hung and
        replaced (default: 15).
    attempts : int
        Tries per frame, each in a fresh child after a hang or crash
        (default: 3).

    Examples
    --------
    >>> with Renderer(size=256) as renderer:                  # doctest: +SKIP
    ...     images = renderer.render(mesh, [[0, 0, 1], [1, 1, 1]])
    >>> images.shape                                          # doctest: +SKIP
    (2, 256, 256, 3)
    """

    def __init__(
        self,
        *,
        size: int = 512,
        camera: Camera | None = None,
        style: RenderStyle | None = None,
        start_timeout: float = _START_TIMEOUT,
        frame_timeout: float = _FRAME_TIMEOUT,
        attempts: int = _ATTEMPTS,
    ) -> None:
        self.size = check_int(size, "size", minimum=16, maximum=4096)
        self.camera = camera or Camera()
        self.style = style or RenderStyle()
        for name, value in (("start_timeout", start_timeout), ("frame_timeout", frame_timeout)):
            if not (isinstance(value, (int, float)) and value > 0):
                raise InputError(f"{name}: expected a positive number of seconds, got {value!r}")
        self.start_timeout = float(start_timeout)
        self.frame_timeout = float(frame_timeout)
        self.attempts = check_int(attempts, "attempts", minimum=1)
        self.open3d_version: str | None = None
        self.n_restarts = 0
        self._child: _Child | None = None
        self._mesh: Mesh | None = None
        self._shading: tuple[NDArray[Any], ...] | None = None
        self._frame_of_mesh: tuple[NDArray[np.float64], float] | None = None

    # ---------------------------------------------------------------- lifetime

    def start(self) -> Renderer:
        """Start the child now (else the first frame does).

        Returns
        -------
        self : Renderer

        Raises
        ------
        MissingDependencyError
            If Open3D is missing, or its renderer cannot start (no Vulkan
            driver) or finish a warm-up frame in any of ``attempts`` tries.
        """
        if self._child is not None and self._child.process.poll() is None:
            return self
        self._stop_child(is_polite=False)
        problem = ""
        for _ in range(self.attempts):
            child = _Child(self.size, self.style)
            try:
                created, _ = child.receive(self.start_timeout)
                if not created.get("ok"):
                    child.close(is_polite=False)
                    raise MissingDependencyError(f"renderer: {created.get('error')}")
                self.open3d_version = str(created.get("open3d"))
                ready, _ = child.receive(self.start_timeout)
                if not ready.get("ok"):
                    problem = str(ready.get("error"))
                    child.close(is_polite=False)
                    break
            except _ChildDied as err:
                reason = child.stderr_reason()
                child.close(is_polite=False)
                raise MissingDependencyError(
                    "renderer: Open3D's offscreen renderer could not start (no Vulkan driver?): "
                    + one_line(f"{err}; {reason}" if reason else str(err))
                ) from None
            except _ChildTimedOut as err:
                problem = f"{err} ({child.stderr_reason() or 'no message'})"
                child.close(is_polite=False)
                self.n_restarts += 1
                continue
            self._child = child
            return self
        raise MissingDependencyError(
            "renderer: Open3D's offscreen renderer could not start (no Vulkan driver?): "
            + one_line(f"{problem}, {self.attempts} attempts")
        )

    def close(self) -> None:
        """Stop the child process (the renderer may be started again)."""
        self._stop_child(is_polite=True)

    def _stop_child(self, *, is_polite: bool) -> None:
        if self._child is not None:
            self._child.close(is_polite=is_polite)
            self._child = None

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __del__(self) -> None:
        child = getattr(self, "_child", None)
        if child is not None and child.process.poll() is None:
            child.process.kill()

    # ---------------------------------------------------------------- frames

    def _prepare(self, mesh: Mesh) -> None:
        if self._mesh is mesh:
            return
        centre, diagonal = bounding_frame(mesh)
        if not diagonal > 0.0:
            raise InputError(f"{mesh.name}: model has zero extent")
        self._shading = crease_normals(mesh, self.style.crease_angle_deg)
        self._frame_of_mesh = (centre, diagonal)
        self._mesh = mesh

    def _faces_to_draw(self, eye: NDArray[np.float64]) -> NDArray[np.int64]:
        assert self._shading is not None  # noqa: S101 (set by _prepare)
        _, _, face_points, face_normals, _ = self._shading
        if not self.camera.cull_back_faces:
            return np.arange(len(face_points), dtype=np.int64)
        facing = np.einsum("ij,ij->i", eye[None, :] - face_points, face_normals) > 0.0
        return np.flatnonzero(facing).astype(np.int64)

    def _render_once(self, mesh: Mesh, frame: _Frame,
                     faces: NDArray[np.int64]) -> NDArray[np.uint8]:
        child = self._child
        assert child is not None and self._shading is not None  # noqa: S101
        if child.mesh_key != id(mesh):
            positions, normals, _, _, _ = self._shading
            child.send({"op": "mesh"}, {"positions": positions, "normals": normals})
            answer, _ = child.receive(self.frame_timeout)
            if not answer.get("ok"):
                raise MeasurementError(f"{mesh.name}: renderer: {answer.get('error')}")
            child.mesh_key = id(mesh)
        child.send(
            {
                "op": "frame",
                "eye": frame.eye.tolist(),
                "centre": frame.centre.tolist(),
                "up": frame.up.tolist(),
                "light": frame.light.tolist(),
                "near": frame.near,
                "far": frame.far,
                "fov_deg": self.camera.fov_deg,
            },
            {"faces": faces},
        )
        answer, arrays = child.receive(self.frame_timeout)
        if not answer.get("ok"):
            raise MeasurementError(f"{mesh.name}: renderer: {answer.get('error')}")
        image = arrays["image"]
        if image.shape != (self.size, self.size, 3) or image.dtype != np.uint8:
            raise MeasurementError(f"{mesh.name}: renderer returned an image of shape "
                                   f"{image.shape} and dtype {image.dtype}")
        return image.copy()

    def render(self, mesh: Mesh, directions: ArrayLike) -> NDArray[np.uint8]:
        """Draw a mesh from each of several view directions.

        Parameters
        ----------
        mesh : Mesh
            The model.
        directions : (n, 3) or (3,) array_like
            View directions from the model centre towards the camera (any
            non-zero length).

        Returns
        -------
        images : (n, size, size, 3) uint8
            sRGB pictures, row 0 at the top (a single direction gives ``n = 1``).

        Raises
        ------
        InputError
            On bad directions or a mesh of zero extent.
        MissingDependencyError
            If the renderer cannot start at all.
        MeasurementError
            If a frame failed (hung or crashed) in all ``attempts`` tries.
        """
        if not isinstance(mesh, Mesh):
            raise InputError(f"mesh: expected a vptoolkit Mesh, got {type(mesh).__name__}")
        unit = as_directions(directions, name="directions")
        self._prepare(mesh)
        assert self._frame_of_mesh is not None  # noqa: S101 (set by _prepare)
        centre, diagonal = self._frame_of_mesh
        images = np.zeros((len(unit), self.size, self.size, 3), dtype=np.uint8)
        for row, direction in enumerate(unit):
            frame = _frame(self.camera, self.style, direction, centre, diagonal, self.size)
            faces = self._faces_to_draw(frame.eye)
            problem = ""
            for attempt in range(self.attempts):
                self.start()
                if attempt:
                    # Lavapipe's slow frames depend on the triangle order; the
                    # z-buffer makes the picture independent of it.
                    faces = np.random.default_rng(attempt).permutation(faces)
                try:
                    images[row] = self._render_once(mesh, frame, faces)
                    break
                except _ChildTimedOut as err:
                    problem = f"{err}"
                except _ChildDied as err:
                    assert self._child is not None  # noqa: S101
                    reason = self._child.stderr_reason()
                    problem = f"the render process died ({err}{'; ' + reason if reason else ''})"
                self._stop_child(is_polite=False)
                self.n_restarts += 1
            else:
                raise MeasurementError(
                    f"{mesh.name}: renderer: {one_line(problem)} in {self.attempts} attempts"
                )
        return images


# --------------------------------------------------------------------------- functions


def check_renderer(*, timeout: float = _START_TIMEOUT) -> str:
    """Start a tiny renderer child to see whether pictures can be made here.

    Parameters
    ----------
    timeout : float
        Seconds allowed for the start (default: 120).

    Returns
    -------
    version : str
        The Open3D version the child rendered with.

    Raises
    ------
    MissingDependencyError
        One line: Open3D missing, or its renderer unable to start.
    """
    with Renderer(size=16, start_timeout=timeout) as renderer:
        renderer.start()
        return str(renderer.open3d_version)


ENGINES = ("software", "open3d")
"""Picture engines: ``"software"`` (:class:`vptoolkit.software_render.SoftwareRenderer`,
the measures' rasteriser and numpy shading, in this process) and ``"open3d"``
(:class:`Renderer`, Open3D's Filament in a child process)."""

AnyRenderer = Any
"""A :class:`Renderer` or a :class:`vptoolkit.software_render.SoftwareRenderer`."""


def open_renderer(engine: str = "software", *, size: int = 512, camera: Camera | None = None,
                  style: RenderStyle | None = None) -> AnyRenderer:
    """A renderer of the given engine (not started), for use as a context manager.

    Parameters
    ----------
    engine : {"software", "open3d"}
        ``"software"`` (default) draws in this process in a fraction of a
        second for any view; ``"open3d"`` uses Filament's physically based
        shading through Vulkan, whose frame time on Mesa's software driver
        ranges from 0.1 s to minutes depending on the view.
    size, camera, style
        As for :class:`Renderer`.

    Raises
    ------
    InputError
        On an unknown engine.
    """
    if engine == "open3d":
        return Renderer(size=size, camera=camera, style=style)
    if engine == "software":
        from vptoolkit.software_render import SoftwareRenderer

        return SoftwareRenderer(size=size, camera=camera, style=style)
    raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")


def render_views(
    mesh: Mesh,
    directions: ArrayLike,
    *,
    size: int = 512,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: AnyRenderer | None = None,
    engine: str = "software",
) -> NDArray[np.uint8]:
    """Draw a mesh from several view directions in one child process.

    Parameters
    ----------
    mesh : Mesh
        The model.
    directions : (n, 3) or (3,) array_like
        View directions from the model centre towards the camera.
    size : int
        Picture side in pixels (default: 512); ignored when ``renderer`` is given.
    camera : Camera, optional
        Camera conventions (default: those of the measures).
    style : RenderStyle, optional
        Shading.
    renderer : Renderer or SoftwareRenderer, optional
        An open renderer to reuse (its size, camera and style apply).
    engine : {"software", "open3d"}
        Engine of a renderer made for this call (default: "software"; see
        :func:`open_renderer`).

    Returns
    -------
    images : (n, size, size, 3) uint8
    """
    if renderer is not None:
        return renderer.render(mesh, directions)
    with open_renderer(engine, size=size, camera=camera, style=style) as own:
        return own.render(mesh, directions)


def render_view(
    mesh: Mesh,
    direction: ArrayLike,
    *,
    size: int = 512,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: AnyRenderer | None = None,
    engine: str = "software",
) -> NDArray[np.uint8]:
    """Draw a mesh from one view direction.

    Parameters
    ----------
    mesh : Mesh
        The model.
    direction : (3,) array_like
        View direction from the model centre towards the camera.
    size : int
        Picture side in pixels (default: 512); ignored when ``renderer`` is given.
    camera : Camera, optional
        Camera conventions (default: ``Camera()``, those of the measures).
    style : RenderStyle, optional
        Shading.
    renderer : Renderer or SoftwareRenderer, optional
        An open renderer to reuse.
    engine : {"software", "open3d"}
        Engine of a renderer made for this call (default: "software").

    Returns
    -------
    image : (size, size, 3) uint8
        sRGB picture, row 0 at the top.

    Raises
    ------
    InputError
        On a bad direction.
    MissingDependencyError
        If no renderer can start here (e.g. no Vulkan driver).
    MeasurementError
        If the frame failed in every attempt.
    """
    unit = as_directions(direction, name="direction")
    if len(unit) != 1:
        raise InputError(f"direction: expected one direction, got {len(unit)}")
    return render_views(mesh, unit, size=size, camera=camera, style=style,
                        renderer=renderer, engine=engine)[0]


def resolve_direction(mesh: Mesh, source: DirectionSource, *,
                      measure: str = "VE") -> NDArray[np.float64]:
    """The view direction a direction source gives for a mesh and measure.

    Parameters
    ----------
    mesh : Mesh
        The model (passed to ``source`` if it is callable).
    source : (3,) or (4, 3) array_like, or callable
        A direction, one direction per measure in ``MEASURES`` order, or a
        callable ``source(mesh)`` returning either (the hook for a trained
        network, e.g. a wrapper around ``vptoolkit.learn.predict``).
    measure : str
        Row to take from a ``(4, 3)`` result (default: "VE").

    Returns
    -------
    direction : (3,) float64
        Unit vector.

    Raises
    ------
    InputError
        On an unknown measure, a wrong shape, or a zero or non-finite vector.
    """
    column = measure_index(measure)
    value = source(mesh) if callable(source) else source
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{mesh.name}: predicted direction is not numeric ({err})") from err
    if array.shape == (len(MEASURES), 3):
        array = array[column]
    elif array.shape == (1, 3):
        array = array[0]
    if array.shape != (3,):
        raise InputError(f"{mesh.name}: expected a (3,) or ({len(MEASURES)}, 3) direction, "
                         f"got shape {array.shape}")
    return as_directions(array, name=f"{mesh.name}: direction")[0]


def render_best(
    mesh: Mesh,
    *,
    measure: str = "VE",
    size: int = 512,
    quality: ViewQuality | None = None,
    n_views: int = N_VIEWS,
    resolution: int = RESOLUTION,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: AnyRenderer | None = None,
    engine: str = "software",
) -> RenderedView:
    """Draw a mesh from its best view for one measure.

    The measures are computed first (:func:`vptoolkit.measures.compute_view_quality`
    with ``n_views`` and ``resolution``) unless ``quality`` is given; the
    picture uses the same camera conventions.

    Parameters
    ----------
    mesh : Mesh
        The model.
    measure : str
        ``"VE"``, ``"VR"``, ``"VKL"`` or ``"VMI"`` (default: "VE").
    size : int
        Picture side in pixels (default: 512).
    quality : ViewQuality, optional
        Measures already computed for this mesh.
    n_views, resolution : int
        Views and triangle-ID resolution of the measures (defaults: 1000, 1024).
    camera : Camera, optional
        Camera conventions for both measures and picture (default: ``Camera()``).
    style : RenderStyle, optional
        Shading.
    renderer : Renderer or SoftwareRenderer, optional
        An open renderer to reuse.
    engine : {"software", "open3d"}
        Engine of a renderer made for this call (default: "software").

    Returns
    -------
    RenderedView
        ``label`` reads e.g. ``"best VE (view 17 of 1000)"``.
    """
    column = measure_index(measure)
    if quality is None:
        from vptoolkit.measures import compute_view_quality

        quality = compute_view_quality(mesh, n_views, resolution, camera=camera)
    index = int(quality.best_index[column])
    direction = quality.views[index]
    image = render_view(mesh, direction, size=size, camera=camera or quality.camera,
                        style=style, renderer=renderer, engine=engine)
    return RenderedView(image, direction.copy(),
                        f"best {MEASURES[column]} (view {index} of {len(quality.views)})")


def render_predicted(
    mesh: Mesh,
    source: DirectionSource,
    *,
    measure: str = "VE",
    size: int = 512,
    camera: Camera | None = None,
    style: RenderStyle | None = None,
    renderer: AnyRenderer | None = None,
    engine: str = "software",
) -> RenderedView:
    """Draw a mesh from a predicted view direction.

    Parameters
    ----------
    mesh : Mesh
        The model.
    source : (3,) or (4, 3) array_like, or callable
        See :func:`resolve_direction`; a callable gets the mesh and returns
        the prediction (the hook for ``vptool render --model``).
    measure : str
        Measure whose prediction to draw (default: "VE").
    size : int
        Picture side in pixels (default: 512).
    camera, style, renderer, engine
        As for :func:`render_view`.

    Returns
    -------
    RenderedView
        ``label`` reads e.g. ``"predicted VE"``.
    """
    direction = resolve_direction(mesh, source, measure=measure)
    image = render_view(mesh, direction, size=size, camera=camera, style=style,
                        renderer=renderer, engine=engine)
    return RenderedView(image, direction, f"predicted {MEASURES[measure_index(measure)]}")


# --------------------------------------------------------------------------- PNG


def _png_chunk(tag: bytes, body: bytes) -> bytes:
    return (struct.pack(">I", len(body)) + tag + body
            + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF))


def png_bytes(image: ArrayLike) -> bytes:
    """Encode an 8-bit image as PNG (zlib only, no imaging library).

    Parameters
    ----------
    image : (height, width), (height, width, 3) or (height, width, 4) uint8
        Grey, RGB or RGBA; row 0 at the top.

    Returns
    -------
    png : bytes
    """
    array = np.asarray(image)
    if array.dtype != np.uint8:
        raise InputError(f"image: expected dtype uint8, got {array.dtype}")
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in (1, 3, 4) or 0 in array.shape:
        raise InputError(
            f"image: expected shape (h, w), (h, w, 3) or (h, w, 4), got {np.shape(image)}"
        )
    height, width, channels = array.shape
    color_type = {1: 0, 3: 2, 4: 6}[channels]
    rows = np.zeros((height, 1 + width * channels), dtype=np.uint8)  # filter byte 0 per row
    rows[:, 1:] = array.reshape(height, -1)
    header = struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", header)
            + _png_chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + _png_chunk(b"IEND", b""))


def save_png(image: ArrayLike, path: str | os.PathLike[str]) -> Path:
    """Write an 8-bit image to a PNG file atomically.

    Parameters
    ----------
    image : (height, width), (height, width, 3) or (height, width, 4) uint8
        E.g. from :func:`render_view`.
    path : path-like
        Target ending in ``.png``; its folder must exist.

    Returns
    -------
    path : pathlib.Path
        The written file.

    Raises
    ------
    InputError
        On a wrong suffix, a missing folder, or a wrong shape or dtype.
    """
    target = check_suffix(as_path(path, "path"), ".png")
    if not target.parent.is_dir():
        raise InputError(f"{target}: folder {target.parent} does not exist")
    return write_bytes_atomic(target, png_bytes(image))
