"""VTU time series of particles (one ``vertex`` cell per particle) with a ``.pvd`` index for ParaView.

Open ``<out>/particles.pvd`` in ParaView: the frames load as one time series;
colour by any point field and use the *Point Gaussian* representation to draw
particles as spheres.

Frames are VTK XML files (``.vtu``, one ``vertex`` cell per particle) written by
:func:`write_vtu`: binary data appended raw (no base64, which costs a third more), each array in
blocks of 1 MiB compressed with zlib at level 1 (VTK's ``vtkZLibDataCompressor``), positions and
floating-point fields in single precision (``[run] frame_compression``, ``frame_precision``; the
reasons per field are in docs/mpm.md, "Frame files"). A 72,552-particle frame of the main job
(``examples/tissue_block.toml``, default fields) holds 3.6 MB instead of 13.5 MB for the base64
uncompressed VTU that meshio wrote before. ParaView, VTK's ``vtkXMLUnstructuredGridReader`` and
meshio read every combination. Which fields a run writes is chosen by ``[run] fields`` (:mod:`tissuempm.io.frames`).

Fields written per particle (units SI; floating-point fields in single precision unless
``precision="double"``: the checkpoint keeps full precision):

==================  ======  ===============================================
velocity            3       velocity [m/s]
F                   9       deformation gradient (row-major; ParaView tensor)
stress              9       Cauchy stress [Pa], tension positive
pressure            1       -tr(stress)/3 [Pa]
von_mises           1       sqrt(3/2 s:s), s the stress deviator [Pa]
J                   1       det F
fiber               3       reference fiber direction a0
fiber_current       3       current fiber direction F a0 / |F a0|
fiber_stretch       1       |F a0|
<state variable>    k       each material's history variables by name
(other arrays)      ...     every other per-particle array of the state
==================  ======  ===============================================
"""

import xml.etree.ElementTree as ET
import zlib
from pathlib import Path
from typing import Any, Literal
from xml.sax.saxutils import quoteattr

import numpy as np

from tissuempm.io.files import atomic_path

_SKIP = {"x", "order", "vpic", "removed"}  # points; storage permutation, PIC scratch velocity, removal totals


def _flat(a: np.ndarray, n: int) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype == bool:
        a = a.astype(np.uint8)
    if a.ndim > 2:
        a = a.reshape(n, -1)
    if a.ndim == 2 and a.shape[1] == 1:
        a = a[:, 0]
    return a


def state_fields(state: np.ndarray, material: np.ndarray, materials: list[Any]) -> dict[str, np.ndarray]:
    """Name the history columns of ``state`` (n, k) by each material's ``state_layout()``.

    A variable shared by several materials (same name) is one field; particles of a
    material without it get 0.
    """
    out: dict[str, np.ndarray] = {}
    state = np.asarray(state)
    for mid, mat in enumerate(materials):
        layout = mat.state_layout() if hasattr(mat, "state_layout") else {}
        rows = material == mid
        for name, sl in layout.items():
            width = sl.stop - sl.start
            zeros = np.zeros((len(state), width)) if width > 1 else np.zeros(len(state))
            field = out.setdefault(name, zeros)
            vals = state[rows, sl]
            field[rows] = vals if width > 1 else vals[:, 0]
    return out


def particle_fields(data: dict[str, Any], materials: list[Any] | None = None) -> dict[str, np.ndarray]:
    """Per-particle point data for a VTU frame from a ``State.to_numpy()`` dict.

    ``x`` becomes the points (not a field); ``v`` is written as ``velocity``;
    derived fields (table in the module docstring) are added when ``F``,
    ``stress`` and ``fiber`` are present; ``state`` is split into named history
    variables when ``materials`` is given. Scalars (``time``, ``step``) are skipped.
    Floating-point fields come back as float64, booleans as uint8; :func:`write_vtu`
    stores them in the frame's precision.
    """
    n = len(data["x"])
    out: dict[str, np.ndarray] = {}
    for key, value in data.items():
        a = np.asarray(value)
        if key in _SKIP or a.ndim == 0 or a.shape[0] != n:
            continue
        if key == "state" and materials is not None and "material" in data:
            out.update(state_fields(a, np.asarray(data["material"]), materials))
            continue
        out["velocity" if key == "v" else key] = _flat(a, n)
    if "F" in data:
        F = np.asarray(data["F"]).reshape(n, 3, 3)
        out.setdefault("J", np.linalg.det(F))
        if "fiber" in data:
            a = np.einsum("nij,nj->ni", F, np.asarray(data["fiber"]).reshape(n, 3))
            stretch = np.linalg.norm(a, axis=1)
            out["fiber_stretch"] = stretch
            out["fiber_current"] = a / np.where(stretch > 0, stretch, 1.0)[:, None]
    if "stress" in data:
        s = np.asarray(data["stress"]).reshape(n, 3, 3)
        p = -np.trace(s, axis1=1, axis2=2) / 3.0
        dev = s + p[:, None, None] * np.eye(3)
        out["pressure"] = p
        out["von_mises"] = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
    return out  # floating-point fields in double precision: the writer stores them as asked (write_vtu)


Compression = Literal["zlib", "none"]
Precision = Literal["single", "double"]
COMPRESSIONS: tuple[str, ...] = ("zlib", "none")
"""``[run] frame_compression``: zlib level 1 (default) or none (fastest to write, 2-3 times larger)."""
PRECISIONS: tuple[str, ...] = ("single", "double")
"""``[run] frame_precision``: positions and floating-point fields as float32 (default) or float64."""
ZLIB_LEVEL = 1
"""Deflate level: level 1 compresses the main job's frame 3 times faster than the default 6, for 0.5 % more bytes."""
BLOCK_BYTES = 1 << 20
"""Uncompressed bytes per compressed block (VTK's reader takes any size; its writer uses 32 KiB)."""
VTK_VERTEX = 1
"""VTK cell type of a single point."""
_VTK_TYPES = {
    "f4": "Float32", "f8": "Float64", "i1": "Int8", "u1": "UInt8", "i2": "Int16", "u2": "UInt16",
    "i4": "Int32", "u4": "UInt32", "i8": "Int64", "u8": "UInt64",
}  # fmt: skip
"""VTK's name of each numpy type (kind and bytes)."""


def _stored(a: np.ndarray, n: int, real: type) -> np.ndarray:
    """``a`` as written: (n,) or (n, k) little-endian, floating point as ``real``, booleans as uint8."""
    a = np.asarray(a)
    if a.dtype.kind == "f":
        with np.errstate(over="ignore"):  # a value beyond float32 is written as inf: the run reports why
            a = a.astype(real, copy=False)
    elif a.dtype == bool:
        a = a.astype(np.uint8)
    if f"{a.dtype.kind}{a.dtype.itemsize}" not in _VTK_TYPES:
        raise TypeError(f"cannot write a {a.dtype} array to a VTU frame")
    a = a.astype(a.dtype.newbyteorder("<"), copy=False)
    if a.shape[:1] != (n,):
        raise ValueError(f"array of shape {a.shape}: a frame of {n} particles needs {n} rows")
    return np.ascontiguousarray(a.reshape(n, -1) if a.ndim > 2 else a)


def _encoded(a: np.ndarray, level: int | None) -> bytes:
    """``a`` as VTK's appended raw data (``header_type="UInt64"``): without compression the byte
    count then the bytes; with zlib the block header ``[blocks, block size, size of the last block
    (0: full), compressed size of each block]`` then the compressed blocks (VTK file formats,
    "Compressed data")."""
    raw = a.reshape(-1).view(np.uint8).data  # the bytes as a memoryview, without a copy
    if level is None:
        return np.uint64(len(raw)).astype("<u8").tobytes() + raw.tobytes()
    blocks = [zlib.compress(raw[i : i + BLOCK_BYTES], level) for i in range(0, len(raw), BLOCK_BYTES)]
    header = np.array([len(blocks), BLOCK_BYTES, len(raw) % BLOCK_BYTES, *map(len, blocks)], dtype="<u8")
    return header.tobytes() + b"".join(blocks)


def write_vtu(
    path: str | Path,
    points: np.ndarray,
    fields: dict[str, np.ndarray],
    compression: Compression = "zlib",
    precision: Precision = "single",
) -> None:
    """Write particles as a VTK XML unstructured grid ``path`` (one vertex cell per point).

    Parameters
    ----------
    path
        The ``.vtu`` file (written as given: :class:`VTUSeries` renames a temporary one).
    points
        Positions, (n, 3) [m].
    fields
        Point data by name, each with n rows: (n,), (n, k) or (n, ...) (flattened per point).
    compression
        ``"zlib"`` (deflate level :data:`ZLIB_LEVEL`, blocks of :data:`BLOCK_BYTES`) or ``"none"``.
    precision
        ``"single"``: positions and floating-point fields as float32; ``"double"``: float64.
        Integer fields keep their type, booleans are written as uint8.

    Notes
    -----
    The binary data follows the XML in an ``<AppendedData encoding="raw">`` section (offsets
    into it in each ``DataArray``), ``header_type="UInt64"``, little-endian; connectivity and
    offsets are Int32 below 2**31 points. A frame of no point is written without compression
    (nothing to compress).

    References
    ----------
    Kitware, "VTK File Formats", VTK User's Guide 11th ed. and docs.vtk.org: XML file formats,
    ``AppendedData`` (raw encoding) and compressed binary data (block header layout).
    """
    if compression not in COMPRESSIONS:
        raise ValueError(f"compression = {compression!r}: valid are {', '.join(map(repr, COMPRESSIONS))}")
    if precision not in PRECISIONS:
        raise ValueError(f"precision = {precision!r}: valid are {', '.join(map(repr, PRECISIONS))}")
    real = np.float32 if precision == "single" else np.float64
    n = len(points)
    level = ZLIB_LEVEL if compression == "zlib" and n > 0 else None
    index = np.int32 if n < 2**31 - 1 else np.int64
    arrays: list[tuple[str, str, np.ndarray]] = [("Points", "Points", _stored(points, n, real).reshape(n, 3))]
    arrays += [
        ("Cells", "connectivity", np.arange(n, dtype=index)),
        ("Cells", "offsets", np.arange(1, n + 1, dtype=index)),
        ("Cells", "types", np.full(n, VTK_VERTEX, dtype=np.uint8)),
    ]
    arrays += [("PointData", str(name), _stored(a, n, real)) for name, a in fields.items()]
    blobs = [_encoded(a, level) for _, _, a in arrays]
    offsets = np.concatenate([[0], np.cumsum([len(b) for b in blobs])])
    compressor = ' compressor="vtkZLibDataCompressor"' if level is not None else ""
    xml = [
        '<?xml version="1.0"?>',
        f'<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64"{compressor}>',
        "  <UnstructuredGrid>",
        f'    <Piece NumberOfPoints="{n}" NumberOfCells="{n}">',
    ]
    section = None
    for (sec, name, a), offset in zip(arrays, offsets[:-1], strict=True):
        if sec != section:
            if section is not None:
                xml.append(f"      </{section}>")
            xml.append(f"      <{sec}>")
            section = sec
        comps = f' NumberOfComponents="{a.shape[1]}"' if a.ndim == 2 else ""
        xml.append(
            f'        <DataArray type="{_VTK_TYPES[f"{a.dtype.kind}{a.dtype.itemsize}"]}" Name={quoteattr(name)}'
            f'{comps} format="appended" offset="{offset}"/>'
        )
    xml += [f"      </{section}>", "    </Piece>", "  </UnstructuredGrid>", '  <AppendedData encoding="raw">', "   _"]
    with open(path, "wb") as f:
        f.write("\n".join(xml).encode("utf-8"))
        for blob in blobs:
            f.write(blob)
        f.write(b"\n  </AppendedData>\n</VTKFile>\n")  # the newline ends the data for meshio's reader


def write_pvd(path: str | Path, frames: list[tuple[float, str]]) -> None:
    """Write a ParaView collection ``path`` listing ``(time, file)`` frames (files relative to it)."""
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for time, file in frames:
        ET.SubElement(coll, "DataSet", timestep=repr(float(time)), group="", part="0", file=file)
    ET.indent(root)
    with atomic_path(path) as tmp:
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")


def read_pvd(path: str | Path) -> list[tuple[float, str]]:
    """The ``(time, file)`` frames listed in a ``.pvd`` collection."""
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep", "0")), d.get("file", "")) for d in root.iter("DataSet")]


class VTUSeries:
    """A growing VTU time series in ``directory``: frames in ``frames/``, index ``<name>.pvd``.

    Parameters
    ----------
    directory
        Output folder.
    name
        Stem of the ``.pvd`` index and of the frame files.
    frames
        Frames already written (``(time, relative file)``), e.g. when a run restarts.
    compression, precision
        How :meth:`write` stores the frames (:func:`write_vtu`; ``[run] frame_compression`` and
        ``frame_precision``).
    """

    def __init__(
        self,
        directory: str | Path,
        name: str = "particles",
        frames: list[tuple[float, str]] | None = None,
        compression: Compression = "zlib",
        precision: Precision = "single",
    ):
        self.directory = Path(directory)
        self.name = name
        self.frames: list[tuple[float, str]] = list(frames or [])
        self.compression: Compression = compression
        self.precision: Precision = precision

    @property
    def pvd(self) -> Path:
        return self.directory / f"{self.name}.pvd"

    def write(
        self, time: float, points: np.ndarray, fields: dict[str, np.ndarray], compression: Compression | None = None
    ) -> Path:
        """Write one frame at ``time`` [s] and update the ``.pvd`` index; returns the frame's path.
        ``compression``: ``"zlib"`` or ``"none"`` for this frame (default: the series')."""
        rel = f"frames/{self.name}_{len(self.frames):05d}.vtu"
        path = self.directory / rel
        with atomic_path(path) as tmp:
            write_vtu(tmp, points, fields, compression or self.compression, self.precision)
        self.frames.append((float(time), rel))
        write_pvd(self.pvd, self.frames)
        return path

    def truncate(self, count: int) -> None:
        """Keep the first ``count`` frames (a restart rewrites the later ones)."""
        for _, rel in self.frames[count:]:
            (self.directory / rel).unlink(missing_ok=True)
        self.frames = self.frames[:count]
        write_pvd(self.pvd, self.frames)
