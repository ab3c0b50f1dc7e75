"""Reading a user's NPZ file safely: every array's header (dtype and shape) is checked before a
byte of its data is read, so a damaged file, a file of another kind, an array of objects, dates or
text, or a header that claims 75 GiB each get one line naming the file and the array, never a
traceback, a ``MemoryError`` or advice to unpickle it.

An NPZ file is a zip archive of ``.npy`` arrays (``numpy.savez``); tofjax reads numbers only
(booleans, integers, floats), never pickled objects.
"""

from __future__ import annotations

import os
import zipfile
import zlib

import numpy as np

from ._limits import size_text

_ZIP_MAGIC = b"PK\x03\x04"
_EMPTY_ZIP_MAGIC = b"PK\x05\x06"
_NPY_MAGIC = b"\x93NUMPY"


def _fail(path, message: str):
    raise ValueError(f"{path}: {message}")


def _archive(path) -> zipfile.ZipFile:
    """The zip archive of an NPZ file (``ValueError`` naming what the file is instead)."""
    name = str(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(64)
    except FileNotFoundError:
        _fail(name, "no such file")
    except IsADirectoryError:
        _fail(name, "is a directory, not an NPZ file")
    except OSError as err:
        _fail(name, f"cannot read: {err.strerror or err}")
    if not head:
        _fail(name, "is empty: an NPZ file is a zip archive of .npy arrays (as numpy.savez writes)")
    if head.startswith(_NPY_MAGIC):
        _fail(name, "is a single NumPy array (.npy), not an NPZ archive of named arrays: write it with "
                    "numpy.savez(path, z_m=array) (or the names the command asks for)")
    if not head.startswith((_ZIP_MAGIC, _EMPTY_ZIP_MAGIC)):
        shown = head[:16].decode("ascii", "replace").encode("unicode_escape").decode("ascii")
        _fail(name, f"is not an NPZ file (it starts with '{shown}'): an NPZ file is a zip archive of .npy arrays, "
                    "as numpy.savez writes")
    try:
        return zipfile.ZipFile(path)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as err:
        _fail(name, f"is damaged (truncated or corrupt: {err})")
    raise AssertionError  # pragma: no cover


def _header(archive: zipfile.ZipFile, member: str, path) -> tuple[tuple[int, ...], np.dtype]:
    try:
        with archive.open(member) as fh:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
            else:
                shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, zlib.error) as err:
        _fail(path, f"array {member.removesuffix('.npy')!r} is damaged (truncated or corrupt: {err})")
    return tuple(int(n) for n in shape), dtype


def npz_arrays(path: str | os.PathLike, wanted: tuple[str, ...], *, max_bytes: int) -> dict[str, np.ndarray]:
    """The arrays ``wanted`` that the NPZ file ``path`` holds (absent ones are left out), as read
    from it. Before reading any: each must hold numbers (``bool``, integer or float: not objects,
    text, dates or records) and all of them together at most ``max_bytes`` as float64. Raises
    ``ValueError`` naming the file (and the array) otherwise."""
    name = str(path)
    with _archive(path) as archive:
        members = {m.removesuffix(".npy"): m for m in archive.namelist() if m.endswith(".npy")}
        headers = {}
        for key in wanted:
            if key not in members:
                continue
            shape, dtype = _header(archive, members[key], name)
            if dtype.kind not in "biuf" or dtype.fields is not None:
                _fail(name, f"array {key!r} has dtype {dtype}: allowed numbers (float, integer or bool)")
            headers[key] = shape
        total = sum(8 * int(np.prod(shape, dtype=np.float64)) for shape in headers.values())
        if total > max_bytes:
            shapes = ", ".join(f"{k} {headers[k]}" for k in headers)
            _fail(name, f"its arrays ({shapes}) would take {size_text(total)} in memory, more than the "
                        f"{size_text(max_bytes)} available")
        out = {}
        for key in headers:
            try:
                with archive.open(members[key]) as fh:
                    out[key] = np.lib.format.read_array(fh, allow_pickle=False)
            except (zipfile.BadZipFile, EOFError, OSError, ValueError, zlib.error) as err:
                _fail(name, f"array {key!r} is damaged (truncated or corrupt: {err})")
        return out


def npz_shapes(path: str | os.PathLike) -> dict[str, tuple[int, ...]]:
    """The shape of every array in the NPZ file ``path``, from their headers only (``ValueError``
    if it is not an NPZ file or is damaged)."""
    with _archive(path) as archive:
        return {m.removesuffix(".npy"): _header(archive, m, str(path))[0] for m in archive.namelist()
                if m.endswith(".npy")}
