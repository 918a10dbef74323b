"""The ``"open3d"`` picture engine: Open3D's offscreen renderer in a child process.

:class:`Renderer` draws what :class:`vptoolkit.pictures.software_engine.SoftwareRenderer`
draws (the camera and :class:`~vptoolkit.pictures.shading.RenderStyle` of
:mod:`vptoolkit.pictures.shading`), with Filament's physically based shading.

Shading
    Open3D's ``defaultLit`` material in the style's colour, or in the
    model's own colours where an :class:`~vptoolkit.appearance.Appearance`
    gives them (vertex, face and base colours as per-corner colours,
    :func:`~vptoolkit.pictures.shading.corner_colors`, times the base-colour
    texture sampled at each corner only, so a texture's detail between
    corners is lost; transparency and normal maps are not drawn), over a
    plain background; normals are smoothed across edges sharper than
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
    Python process (``python -c "from vptoolkit.pictures._open3d_child
    import serve; serve()"``) and talks to it over its standard input and
    output (length-prefixed JSON headers and raw little-endian arrays, no
    pickle; see ``vptoolkit.pictures._open3d_child``). The child renders a
    warm-up frame before it reports ready. If it dies before that,
    :class:`~vptoolkit.errors.MissingDependencyError` says so in one line
    (``renderer: Open3D's offscreen renderer could not start (no Vulkan
    driver?): ...``). A frame that takes longer than ``frame_timeout``
    seconds, or a child that dies during a frame, is retried in a fresh
    child up to ``attempts`` times in all, then raises
    :class:`~vptoolkit.errors.MeasurementError` naming the mesh; the
    renderer stays usable for the next mesh. One child serves any number of
    frames, so a batch pays the start-up (about 1-3 s) once.

Open3D is imported only in the child; this module itself needs numpy alone.
"""

from __future__ import annotations

import math
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.appearance import Appearance
from vptoolkit.camera import Camera
from vptoolkit.checks import check_int, one_line
from vptoolkit.errors import InputError, MeasurementError, MissingDependencyError
from vptoolkit.geometry import bounding_frame
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.pictures._open3d_child import read_message, write_message
from vptoolkit.pictures.shading import (
    PICTURE_SIZE,
    CreaseNormals,
    RenderStyle,
    corner_colors,
    crease_normals,
    engine_setup,
    frame_zoom,
    light_direction,
    picture_camera,
    srgb8_to_linear,
    texture_lookup,
)
from vptoolkit.point_cloud import PointCloud
from vptoolkit.sphere import as_directions

__all__ = ["Renderer", "check_renderer"]

_START_TIMEOUT = 120.0  # seconds for the child to import Open3D and create the renderer
_FRAME_TIMEOUT = 15.0  # seconds for one frame (a 512 x 512 frame takes about 0.25 s)
_ATTEMPTS = 3  # tries per frame: hung or dead children are replaced
_QUIT_TIMEOUT = 5.0  # seconds the child gets to exit before it is killed
_STDERR_TAIL = 4000  # bytes of the child's stderr kept for error messages
_CHILD_CODE = "from vptoolkit.pictures._open3d_child import serve; serve()"


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
    fov_deg: float


def _frame(camera: Camera, style: RenderStyle, direction: NDArray[np.float64],
           centre: NDArray[np.float64], diagonal: float, size: int,
           points: NDArray[np.float64]) -> _Frame:
    """The camera and light of one picture; the field of view narrowed by the
    style's framing (:func:`~vptoolkit.pictures.shading.frame_zoom` of ``points``)."""
    poses = picture_camera(camera, style.up).poses(direction[None, :], centre=centre,
                                                   diagonal=diagonal, resolution=size)
    eye, right, up, forward = poses.eyes[0], poses.right[0], poses.up[0], poses.forward[0]
    distance = camera.distance_factor * diagonal
    radius = diagonal / 2.0
    near = max(distance - 1.05 * radius, 1e-3 * distance)
    far = distance + 1.05 * radius
    zoom = float(frame_zoom(poses, points, style.margin)[0])
    fov_deg = camera.fov_deg if zoom == 1.0 else \
        2.0 * math.degrees(math.atan(math.tan(math.radians(camera.fov_deg) / 2.0) / zoom))
    return _Frame(eye, centre, up, light_direction(style, forward, up, right), near, far,
                  fov_deg)


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
        package_root = str(Path(__file__).resolve().parents[2])  # holds vptoolkit/
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
        self.mesh_key: tuple[int, int] | None = None
        self.send({"op": "start", "size": size, "style": style.to_dict()})

    def _read_answers(self) -> None:
        stream = self.process.stdout
        assert stream is not None  # noqa: S101 (set by Popen)
        try:
            while True:
                self.answers.put(read_message(stream))
        except (EOFError, OSError, ValueError):
            self.answers.put(None)

    def send(self, header: dict[str, Any], arrays: dict[str, NDArray[Any]] | None = None) -> None:
        stream = self.process.stdin
        assert stream is not None  # noqa: S101 (set by Popen)
        try:
            write_message(stream, header, arrays)
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
    size, camera, style
        As :func:`~vptoolkit.pictures.engine.open_renderer` takes them.
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
        size: int = PICTURE_SIZE,
        camera: Camera | None = None,
        style: RenderStyle | None = None,
        start_timeout: float = _START_TIMEOUT,
        frame_timeout: float = _FRAME_TIMEOUT,
        attempts: int = _ATTEMPTS,
    ) -> None:
        self.size, self.camera, self.style = engine_setup(size, camera, style)
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
        self._shading: CreaseNormals | None = None
        self._frame_of_mesh: tuple[NDArray[np.float64], float] | None = None
        self._appearance: Appearance | None = None
        self._colors: NDArray[np.float32] | None = None
        self._points: NDArray[np.float64] = np.zeros((0, 3))

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

    def _prepare(self, mesh: Mesh, appearance: Appearance | None) -> None:
        if self._mesh is mesh and self._appearance is appearance:
            return
        centre, diagonal = bounding_frame(mesh)
        if not diagonal > 0.0:
            raise InputError(f"{mesh.name}: model has zero extent")
        self._shading = crease_normals(mesh, self.style.crease_angle_deg)
        colors = corner_colors(appearance, mesh.faces, mesh.n_vertices)
        if colors is not None and appearance is not None and appearance.texture is not None \
                and appearance.corner_uv is not None:  # the texture at each corner only
            uv = appearance.corner_uv.reshape(-1, 2)
            textured = np.isfinite(uv).all(axis=1)
            flat = colors.reshape(-1, 3)
            flat[textured] *= texture_lookup(srgb8_to_linear(appearance.texture[..., :3]),
                                             uv[textured])
        self._colors = None if colors is None else \
            colors[self._shading.kept].reshape(-1, 3).astype(np.float32)
        self._points = mesh.vertices[np.unique(mesh.faces)]
        self._frame_of_mesh = (centre, diagonal)
        self._mesh, self._appearance = mesh, appearance

    def _faces_to_draw(self, eye: NDArray[np.float64]) -> NDArray[np.int64]:
        assert self._shading is not None  # noqa: S101 (set by _prepare)
        face_points, face_normals = self._shading.face_points, self._shading.face_normals
        if not self.camera.cull_back_faces:
            return np.arange(len(face_points), dtype=np.int64)
        facing = np.einsum("ij,ij->i", eye[None, :] - face_points, face_normals) > 0.0
        return np.flatnonzero(facing).astype(np.int64)

    def _render_once(self, mesh: Mesh, frame: _Frame,
                     faces: NDArray[np.int64]) -> NDArray[np.uint8]:
        child = self._child
        assert child is not None and self._shading is not None  # noqa: S101
        key = (id(mesh), id(self._appearance))
        if child.mesh_key != key:
            corners = {"positions": self._shading.positions, "normals": self._shading.normals}
            if self._colors is not None:
                corners["colors"] = self._colors
            child.send({"op": "mesh"}, corners)
            answer, _ = child.receive(self.frame_timeout)
            if not answer.get("ok"):
                raise MeasurementError(f"{mesh.name}: renderer: {answer.get('error')}")
            child.mesh_key = key
        child.send(
            {
                "op": "frame",
                "eye": frame.eye.tolist(),
                "centre": frame.centre.tolist(),
                "up": frame.up.tolist(),
                "light": frame.light.tolist(),
                "near": frame.near,
                "far": frame.far,
                "fov_deg": frame.fov_deg,
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

    def render(self, mesh: MeshLike | PointCloud, directions: ArrayLike, *,
               appearance: Appearance | None = None) -> NDArray[np.uint8]:
        """Draw a mesh from each of several view directions: ``(n, size, size, 3)`` uint8
        sRGB pictures, in the colours of ``appearance`` where given (its
        texture sampled at the corners only), as
        :meth:`Engine.render <vptoolkit.pictures.engine.Engine.render>`
        specifies (a single direction gives ``n = 1``).

        Raises
        ------
        InputError
            On bad directions or a mesh of zero extent, or a point cloud: this
            engine draws surfaces only (the software engine draws clouds).
        MissingDependencyError
            If the renderer cannot start at all.
        MeasurementError
            If a frame failed (hung or crashed) in all ``attempts`` tries.
        """
        if isinstance(mesh, PointCloud):
            raise InputError(f"{mesh.name}: a point cloud; the open3d engine draws surfaces "
                             "only, the software engine (--engine software) draws clouds")
        mesh = as_mesh(mesh)
        unit = as_directions(directions, name="directions")
        self._prepare(mesh, appearance)
        assert self._frame_of_mesh is not None  # noqa: S101 (set by _prepare)
        centre, diagonal = self._frame_of_mesh
        images = np.zeros((len(unit), self.size, self.size, 3), dtype=np.uint8)
        for row, direction in enumerate(unit):
            frame = _frame(self.camera, self.style, direction, centre, diagonal, self.size,
                           self._points)
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


