"""The Open3D render child: its wire protocol and its main loop (private).

:class:`vptoolkit.pictures.open3d_engine.Renderer` starts ``python -c
"from vptoolkit.pictures._open3d_child import serve; serve()"`` and talks to
it over the child's standard input and output. A message is a JSON header
and named arrays:

* ``<I``: byte length of the JSON header;
* the header, UTF-8 JSON, with ``"arrays": [[name, dtype, shape], ...]``;
* ``<Q``: byte length of the payload;
* the payload: the arrays' raw little-endian bytes, one after the other.

No pickle crosses the pipe. Open3D is imported in the child only, inside
:func:`serve`; importing this module needs numpy alone.
"""

from __future__ import annotations

import json
import os
import struct
import sys
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.errors import MissingDependencyError
from vptoolkit.pictures.shading import RenderStyle, linear_to_srgb, srgb_to_linear

__all__ = ["read_message", "serve", "write_message"]

_HEADER = struct.Struct("<I")  # byte length of a message's JSON header
_PAYLOAD = struct.Struct("<Q")  # byte length of a message's payload


# --------------------------------------------------------------------------- messages


def write_message(stream: IO[bytes], header: dict[str, Any],
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


def read_message(stream: IO[bytes]) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
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


def serve() -> None:
    """Main loop of the render child process.

    Protocol: the parent sends ``start`` (size, style), then any number of
    ``mesh`` (corner positions and normals, and optionally ``colors``, linear
    RGB per corner) and ``frame`` (camera, light
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
        header, _ = read_message(protocol_in)
        size = int(header["size"])
        style_values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v
                                         for k, v in header["style"].items()}
        style = RenderStyle(**style_values)
        try:
            from vptoolkit.optional import require

            o3d = require("open3d")
        except MissingDependencyError as err:
            write_message(protocol_out, {"ok": False, "error": str(err), "missing": True})
            return
        session = _ChildRenderer(o3d, size, style)
        write_message(protocol_out, {"ok": True, "stage": "created", "open3d": o3d.__version__})
        session.warm_up()
        write_message(protocol_out, {"ok": True, "stage": "ready"})
        while True:
            header, arrays = read_message(protocol_in)
            operation = header["op"]
            if operation == "quit":
                write_message(protocol_out, {"ok": True})
                break
            try:
                if operation == "mesh":
                    session.set_mesh(arrays["positions"], arrays["normals"],
                                     arrays.get("colors"))
                    write_message(protocol_out, {"ok": True})
                elif operation == "frame":
                    image = session.render(header, arrays["faces"])
                    write_message(protocol_out, {"ok": True}, {"image": image})
                else:
                    write_message(protocol_out,
                                   {"ok": False, "error": f"unknown op {operation!r}"})
            except (RuntimeError, ValueError, KeyError) as err:
                write_message(protocol_out, {"ok": False, "error": one_line(err)})
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
        self.colors: Any = None
        self.painted = rendering.MaterialRecord()  # white: the vertex colours show
        self.painted.shader = "defaultLit"
        self.painted.base_color = [1.0, 1.0, 1.0, 1.0]
        self.painted.base_roughness = 0.7
        self.painted.base_reflectance = 0.3
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

    def set_mesh(self, positions: NDArray[np.float32], normals: NDArray[np.float32],
                 colors: NDArray[np.float32] | None) -> None:
        self.positions = positions
        self.normals = normals
        self.colors = colors

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
        if self.colors is not None:
            geometry.vertex_colors = o3d.utility.Vector3dVector(
                self.colors[corners].astype(np.float64))
        scene = self.renderer.scene
        if self.has_geometry:
            scene.remove_geometry("model")
            self.has_geometry = False
        if len(faces):
            scene.add_geometry("model", geometry,
                               self.material if self.colors is None else self.painted)
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

