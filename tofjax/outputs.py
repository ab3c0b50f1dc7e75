"""Writing outputs so that none is ever lost, overwritten by surprise or half-written.

Every command of the ``tofjax`` program (and the ``fitting`` and ``measurements`` packages) writes
through this module, by three rules (README, "Outputs"):

1. **Complete or not at all.** A file is written under a temporary name in its own directory
   (``.NAME.partial-<pid>-<random>``, which no reader takes for an output) and renamed into place
   when it is complete (:func:`atomic_path`, :func:`write_bytes`, :func:`write_text`); an output
   directory (``render``, ``calibrate``, ``compare``, ``simulate --report``) is built the same way
   as a whole and swapped into place (:class:`OutputDir`). A run killed at any moment leaves the
   previous output or the complete new one, never a mixture.
2. **An existing output is refused unless the user says so** (:func:`check_output`): the message
   names the file and what it holds (``ow.csv holds 5 measured points (source: measurement,
   created 2026-11-26T09:00:00+00:00); use --resume to continue or --overwrite to replace``).
   ``--overwrite`` replaces it. A file appearing while a run computes (another run writing the
   same name) is not replaced either: the new result is kept beside it under a unique name.
3. **A measurement is replaced only by name.** A tofjax-sweep file whose metadata say ``source:
   measurement`` and that holds at least one row is replaced by no command, ``--overwrite``
   included, unless ``--force-replace-measurement`` is given as well. The Python API's writers
   (:func:`tofjax.sweepfile.write_sweep` and the others) follow rules 1 and 3 and replace other
   files, as ``numpy.save`` does, so that a notebook cell can be run again.

Directories that a command owns (rule 1) carry a marker, ``.tofjax-output.json`` (the command, the
time and the files), so that ``--overwrite`` replaces only what tofjax wrote: a directory holding a
file tofjax did not write is refused even with ``--overwrite`` (it could be the user's data).
"""

from __future__ import annotations

import codecs
import contextlib
import ctypes
import ctypes.util
import datetime as _dt
import hashlib
import json
import os
import re
import secrets
import shutil
from collections.abc import Iterator
from pathlib import Path

from ._limits import size_text

#: The marker file of an output directory written by tofjax (module docstring).
MARKER = ".tofjax-output.json"
#: The option that lets a command replace a measurement (rule 3).
FORCE_MEASUREMENT_OPTION = "--force-replace-measurement"


class OutputError(ValueError):
    """An output that may not be written (it exists, it holds a measurement, it is a directory):
    one line naming the file and what to do. Commands turn it into exit status 2."""


def _limit(directory: Path, name: str, default: int) -> int:
    """The file system's ``PC_NAME_MAX`` or ``PC_PATH_MAX`` at ``directory`` (or its nearest existing
    parent), in bytes; ``default`` where it does not say."""
    for folder in (directory, *directory.parents):
        try:
            return int(os.pathconf(folder, name))
        except FileNotFoundError:
            continue
        except (OSError, ValueError):
            break
    return default


def _name_max(directory: Path) -> int:
    return _limit(directory, "PC_NAME_MAX", 255)


def _shortened(name: str, room: int) -> str:
    """``name``, or where its bytes exceed ``room``, its beginning and a hash of the whole name (so
    that two long names sharing a beginning stay apart)."""
    raw = os.fsencode(name)
    if len(raw) <= room:
        return name
    digest = hashlib.sha1(raw).hexdigest()[:8]
    return raw[: max(room - 9, 1)].decode("utf-8", "ignore") + "~" + digest


#: Room a temporary name adds around an output's name: ``.NAME.replaced-<pid>-<6 hex>`` with a pid of
#: up to 10 digits (the same for every process and both kinds, so that a stale one is found again).
_PARTIAL_ROOM = len(".") + len(".replaced-") + 10 + len("-") + 6


def _partial_stem(path: Path) -> str:
    """The part of ``path``'s temporary names that stands for its name: the name itself, or where the
    temporary name would exceed the file system's limit (a legal name of 230-255 bytes), the name
    shortened (:func:`_shortened`): the output keeps its own name, only its temporary one is short."""
    return _shortened(path.name, _name_max(path.parent) - _PARTIAL_ROOM)


def _beside(path: Path, tag: str, *, keep_suffix: bool = True) -> Path:
    """``NAME-<tag>.SUFFIX`` beside ``path`` (a result kept beside an output that appeared meanwhile;
    a folder: ``NAME-<tag>``), the name shortened to fit the file system's limit."""
    stem, suffix = (path.stem, path.suffix) if keep_suffix else (path.name, "")
    room = _name_max(path.parent) - len(os.fsencode(f"-{tag}{suffix}"))
    return path.with_name(f"{_shortened(stem, room)}-{tag}{suffix}")


def _partial_name(path: Path, kind: str = "partial") -> Path:
    _remove_stale_partials(path)
    return path.parent / f".{_partial_stem(path)}.{kind}-{os.getpid()}-{secrets.token_hex(3)}"


def _remove_stale_partials(path: Path) -> None:
    """Remove the partial outputs of runs that were killed (their process is gone): a killed run
    cannot clean up after itself. ``.replaced-`` leftovers (an earlier output moved aside) are kept:
    they may be the only copy of it."""
    import glob

    with contextlib.suppress(OSError):
        for old in path.parent.glob(f".{glob.escape(_partial_stem(path))}.partial-*-*"):
            try:
                pid = int(old.name.rsplit("-", 2)[-2])
                os.kill(pid, 0)
            except ProcessLookupError:
                shutil.rmtree(old) if old.is_dir() else old.unlink()
            except (ValueError, PermissionError, OSError):
                continue  # not ours to judge: another user's process, or a name we did not make


def _fsync_dir(directory: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system lets a directory be opened or synced
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _commit(tmp: Path, path: Path, replace: bool) -> Path:
    """Rename the complete ``tmp`` to ``path`` (unless the user interrupted the run: then
    ``KeyboardInterrupt``, and ``path`` stays as it was). Without ``replace``, never over a file
    that appeared meanwhile (a hard link fails where the name exists): the result is kept as
    ``NAME-<time>.SUFFIX`` beside it and :class:`OutputError` says so."""
    from .progress import check_interrupt

    check_interrupt()
    if replace:
        os.replace(tmp, path)
        _fsync_dir(path.parent)
        return path
    try:
        os.link(tmp, path)
    except FileExistsError:
        stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%S")
        kept = _beside(path, f"{stamp}-{secrets.token_hex(2)}")
        os.replace(tmp, kept)
        raise OutputError(f"{path} appeared while this run was writing it (another run?): it is left as it is, and "
                          f"this run's output is kept as {kept}") from None
    except OSError:  # no hard links on this file system: the same check, with a short window
        if path.exists():
            os.unlink(tmp)
            raise OutputError(f"{path} appeared while this run was writing it (another run?): it is left as it "
                              "is") from None
        os.replace(tmp, path)
    else:
        os.unlink(tmp)
    _fsync_dir(path.parent)
    return path


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, replace: bool = True, replace_measurement: bool = False) -> Iterator[Path]:
    """A temporary path to write ``path``'s contents to; on leaving the block without an exception
    it is synced and renamed to ``path`` (on an exception it is removed and ``path`` is untouched).

    ``replace``: an existing ``path`` is replaced (``False``: refused if one appears meanwhile, see
    :func:`_commit`). ``replace_measurement``: also a measurement file (rule 3; otherwise
    :class:`OutputError` before anything is written)."""
    path = Path(path)
    if not replace_measurement:
        refuse_measurement(path)
    tmp = _partial_name(path)
    try:
        yield tmp
        if tmp.exists():
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        else:  # the writer wrote nothing: an empty file, as a plain open(path, "w") would leave
            tmp.touch()
        _commit(tmp, path, replace)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_bytes(path: str | os.PathLike, data: bytes, **kwargs) -> Path:
    """Write ``data`` to ``path`` atomically (:func:`atomic_path`'s options)."""
    with atomic_path(path, **kwargs) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text(path: str | os.PathLike, text: str, **kwargs) -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` atomically."""
    return write_bytes(path, text.encode("utf-8"), **kwargs)


def write_npz(path: str | os.PathLike, arrays: dict, *, compressed: bool = True) -> Path:
    """``arrays`` as an NPZ file (``numpy.savez_compressed``, or ``numpy.savez``), atomically."""
    import numpy as np

    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        (np.savez_compressed if compressed else np.savez)(fh, **arrays)
    return Path(path)


def save_figure(fig, path: str | os.PathLike, **savefig_kwargs) -> Path:
    """``fig.savefig`` atomically (the format from ``path``'s suffix)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", **savefig_kwargs)
    return path


# --- what an existing output holds ---------------------------------------------------------------


#: The first line of a tofjax-sweep file, as :func:`tofjax.sweepfile.parse_sweep` reads it and as
#: rule 3 recognises a measurement by it (one pattern for both, so that no file the reader takes for
#: a sweep file escapes the protection): ``# format: NAME/VERSION``, the blanks around the words free
#: (``#format:tofjax-sweep/1``, `` # format: ...``, a tab), matched on the stripped line.
SWEEP_FORMAT_LINE = re.compile(r"#\s*format:\s*(\S+)")


def sweep_format(first_line: str) -> str | None:
    """The format a sweep file's first line names (``tofjax-sweep/4``), or ``None`` if the line names
    none (:data:`SWEEP_FORMAT_LINE`; a byte-order mark before it is the caller's to remove)."""
    match = SWEEP_FORMAT_LINE.fullmatch(first_line.strip())
    return match.group(1) if match else None


def _text_lines(fh, chunk: int = 1 << 20) -> Iterator[str]:
    """The lines of the binary file ``fh`` as ``str.splitlines`` splits its text (the reader's split:
    ``\n``, ``\r\n``, a lone ``\r`` and the other line ends), decoded as UTF-8 with undecodable
    bytes replaced, read in chunks so that a big file is never held whole."""
    decoder = codecs.getincrementaldecoder("utf-8")("replace")
    rest = ""
    while True:
        data = fh.read(chunk)
        text = rest + decoder.decode(data, final=not data)
        if not data:
            yield from text.splitlines()
            return
        lines = text.splitlines(keepends=True)
        last = lines[-1] if lines else ""
        ended = last.splitlines()[0] != last if last else True  # the last piece ends with a line end
        # The last piece may be cut short by the chunk, or end in the "\r" of a "\r\n": kept for the next.
        rest = lines.pop() if lines and (not ended or last.endswith("\r")) else ""
        for line in lines:
            yield line.splitlines()[0]


def _sweep_header(path: Path) -> tuple[dict[str, str], int] | None:
    """A tofjax-sweep file's metadata and number of data rows (``None``: not such a file); reads
    the lines without checking their values (a big file costs one pass over its bytes).

    As lenient as the reader or more (rule 3 must never miss a file the reader reads): a byte-order
    mark, any line ends, the first line as :func:`sweep_format` takes it, any version of the format,
    metadata lines with blanks before their ``#``, and a ``source`` line in any case; a file with
    two ``source`` lines counts as a measurement if either says so."""
    try:
        with open(path, "rb") as fh:
            lines = _text_lines(fh)
            version = sweep_format(next(lines, "").removeprefix("\ufeff"))
            if version is None or not version.lower().startswith("tofjax-sweep/"):
                return None
            meta: dict[str, str] = {}
            for line in lines:
                text = line.strip()
                if not text:
                    continue
                if not text.startswith("#"):
                    break  # the header row
                key, _, value = text[1:].partition(":")
                key, value = key.strip().lower(), value.strip()
                if not (key == "source" and meta.get("source") == "measurement"):
                    meta[key] = value.lower() if key == "source" else value
            rows = sum(1 for raw in lines if raw.strip())  # after the header row
            return meta, rows
    except OSError:
        return None


def is_measurement(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a tofjax-sweep file of a measurement with at least one row (rule 3)."""
    header = _sweep_header(Path(path))
    return header is not None and header[0].get("source") == "measurement" and header[1] > 0


def refuse_measurement(path: str | os.PathLike, what: str = "") -> None:
    """:class:`OutputError` if ``path`` holds a measurement (rule 3)."""
    path = Path(path)
    if path.is_file() and is_measurement(path):
        raise OutputError(f"{what}{describe(path)}: a measurement is replaced only with {FORCE_MEASUREMENT_OPTION} "
                          "(or move it away first)")


def describe(path: str | os.PathLike) -> str:
    """What an existing output holds, in words: ``ow.csv holds 5 measured points (source:
    measurement, created ...)``, ``render holds 14 files of an earlier tofjax render (2026-...)``,
    or ``camera.toml exists (2.1 kB, modified 2026-...)``."""
    path = Path(path)
    if path.is_dir():
        files = [p for p in path.iterdir() if p.name != MARKER]
        marker = _read_marker(path)
        count = f"{len(files)} file{'' if len(files) == 1 else 's'}"
        if marker is not None:
            return (f"{path} holds {count} of an earlier {marker.get('command', 'tofjax run')} "
                    f"({marker.get('created_utc', 'time unknown')})")
        return f"{path} holds {count}"
    header = _sweep_header(path)
    if header is not None:
        meta, rows = header
        source = meta.get("source", "unknown")
        kind = {"measurement": "measured ", "simulation": "simulated "}.get(source, "")
        return (f"{path} holds {rows} {kind}point{'' if rows == 1 else 's'} (source: {source}, created "
                f"{meta.get('created_utc', 'unknown')})")
    stat = path.stat()
    when = _dt.datetime.fromtimestamp(stat.st_mtime, _dt.UTC).isoformat(timespec="seconds")
    return f"{path} exists ({size_text(stat.st_size)}, modified {when})"


def _nonempty(path: Path) -> bool:
    if path.is_dir():
        return any(True for _ in path.iterdir())
    return path.exists() and path.stat().st_size > 0


def _abbreviated(name: str, width: int = 60) -> str:
    return name if len(name) <= width else f"{name[: width // 2 - 2]}...{name[-(width // 2 - 1):]}"


def name_problem(path: str | os.PathLike) -> str | None:
    """Why the file system cannot hold a file named ``path`` (a name longer than its ``NAME_MAX``,
    255 bytes on most, or a path longer than its ``PATH_MAX``), or ``None``: checked before any work,
    where an ``OSError: File name too long`` would otherwise end the run."""
    path = Path(path)
    absolute = Path(os.path.abspath(path))
    for i, part in enumerate(path.parts):
        size, most = len(os.fsencode(part)), _name_max(absolute.parent)
        if part != path.anchor and size > most:
            which = "the name" if i == len(path.parts) - 1 else f"the folder name {_abbreviated(part)!r}"
            return f"{which} is {size} bytes long: this file system allows at most {most} bytes per name"
    size, most = len(os.fsencode(str(absolute))), _limit(absolute.parent, "PC_PATH_MAX", 4096)
    if size >= most:
        return f"the path is {size} bytes long: this file system allows less than {most}"
    return None


def shown_path(path: str | os.PathLike) -> str:
    """``path`` for a message: a name too long to read whole shortened in the middle."""
    path = Path(path)
    return str(Path(*[_abbreviated(part) for part in path.parts])) if path.parts else str(path)


def check_output(path: str | os.PathLike, option: str, *, overwrite: bool = False, force_measurement: bool = False,
                 resume_option: str | None = None, directory: bool = False) -> None:
    """Before any work: may ``path`` be written? Raises :class:`OutputError` naming ``option``:
    a name the file system cannot hold (:func:`name_problem`); an output directory that is the
    working directory or holds it (it is replaced as a whole, :class:`OutputDir`); a file where a
    directory is meant (or the reverse); an existing non-empty output without ``overwrite`` (the
    message says what it holds and offers ``resume_option`` if the command has one); a
    measurement without ``force_measurement`` (rule 3); a directory with files tofjax did not
    write (:class:`OutputDir`). Then makes the parent directory and proves it writable."""
    path = Path(path)
    problem = name_problem(path)
    if problem:
        raise OutputError(f"{option} {shown_path(path)}: {problem}; choose a shorter name")
    if directory:
        here, target = Path.cwd().resolve(), path.resolve()
        if target == here or target in here.parents:
            raise OutputError(f"{option} {path}: {'is' if target == here else 'holds'} the working directory, "
                              "which an output folder cannot replace (it is built beside its place and swapped in "
                              f"whole): name a new folder inside it, e.g. {option} out")
    if directory and path.exists() and not path.is_dir():
        raise OutputError(f"{option} {path}: is a file, not a directory")
    if not directory and path.is_dir():
        raise OutputError(f"{option} {path}: is a directory; give a file name")
    if _nonempty(path):
        if not path.is_dir() and is_measurement(path) and not force_measurement:
            hint = f"use {resume_option} to continue it; " if resume_option else ""
            raise OutputError(f"{option} {describe(path)}: {hint}a measurement is replaced only with "
                              f"{FORCE_MEASUREMENT_OPTION} (or move it away first)")
        if not overwrite:
            how = f"use {resume_option} to continue or --overwrite to replace" if resume_option else \
                "use --overwrite to replace it, or choose another name"
            raise OutputError(f"{option} {describe(path)}; {how}")
        if path.is_dir():
            foreign = foreign_files(path)
            if foreign:
                shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
                raise OutputError(f"{option} {path} holds files tofjax did not write ({shown}): --overwrite replaces a "
                                  "whole output directory, so give a new or empty one")
            measured = [p.name for p in path.iterdir() if p.is_file() and is_measurement(p)]
            if measured and not force_measurement:
                raise OutputError(f"{option} {path} holds the measurement {measured[0]}: it is replaced only with "
                                  f"{FORCE_MEASUREMENT_OPTION} (or move it away first)")
    # An output directory is made only when it is complete (OutputDir): its parent is probed.
    probe_writable(path if directory and path.is_dir() else path.parent, f"{option} {path}")


def probe_writable(directory: Path, what: str) -> None:
    """Make ``directory`` (with its parents) and prove a file can be created in it (a uniquely
    named probe, removed again); ``what`` (``--out FILE``) starts the message of
    :class:`OutputError`."""
    import tempfile

    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory, prefix=".tofjax-probe-"):
            pass
    except OSError as err:
        raise OutputError(f"{what}: cannot write there: {err.strerror or err}") from None


# --- output directories --------------------------------------------------------------------------


def _read_marker(directory: Path) -> dict | None:
    try:
        return json.loads((directory / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def foreign_files(directory: Path) -> list[str]:
    """Names in ``directory`` that no tofjax run wrote (not listed in its marker; a directory
    without a marker: every name)."""
    marker = _read_marker(directory)
    ours = set(marker.get("files", [])) if marker else set()
    return sorted(p.name for p in directory.iterdir() if p.name != MARKER and p.name not in ours)


_RENAME_EXCHANGE = 2


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2(RENAME_EXCHANGE)``); ``False`` where the system
    cannot."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    result = renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE)
    return result == 0


class OutputDir:
    """An output directory written as a whole (rule 1): a context manager whose :attr:`staging`
    directory receives the files; on leaving the block without an exception the marker is written
    and the staging directory takes ``path``'s place (atomically swapped with an earlier output
    where Linux allows, else renamed aside, renamed in and removed); on an exception it is removed
    and ``path`` is untouched.

    Check it first with :func:`check_output` (``directory=True``): this class assumes the user may
    replace what is there. ``command``: recorded in the marker (``tofjax render``). ``replace``:
    an earlier output may be replaced (``--overwrite``); without it, an output that appeared while
    the run computed (another run) is left as it is and this one is kept beside it, named
    ``PATH-<time>``, with :class:`OutputError` saying so."""

    def __init__(self, path: str | os.PathLike, command: str, *, replace: bool = False):
        self.path = Path(os.path.abspath(path))  # a name to swap (".", "a/.." have none of their own)
        self.command = command
        self.replace = replace
        self.staging = _partial_name(self.path)

    def __enter__(self) -> OutputDir:
        self.staging.mkdir(parents=True)
        return self

    def file(self, name: str) -> Path:
        """Where the file ``name`` (a name or a relative path) of the output goes while it is being
        written (its folder made)."""
        path = self.staging / name
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            return
        try:
            self._commit()
        except BaseException:
            shutil.rmtree(self.staging, ignore_errors=True)
            raise

    def _commit(self) -> None:
        from .progress import check_interrupt

        check_interrupt()
        files = sorted(p.name for p in self.staging.iterdir())
        marker = {"command": self.command, "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
                  "files": files}
        write_text(self.staging / MARKER, json.dumps(marker, indent=1) + "\n")
        _fsync_dir(self.staging)
        path = self.path
        if not path.exists():
            os.rename(self.staging, path)
        elif path.is_dir() and not any(True for _ in path.iterdir()):
            os.rename(self.staging, path)  # over an empty directory: allowed, atomic
        elif not self.replace:
            stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%S")
            kept = _beside(path, f"{stamp}-{secrets.token_hex(2)}", keep_suffix=False)
            os.rename(self.staging, kept)
            raise OutputError(f"{path} appeared while this run was writing it (another run?): it is left as it is, "
                              f"and this run's output is kept as {kept}")
        elif _exchange(self.staging, path):
            shutil.rmtree(self.staging, ignore_errors=True)  # now the earlier output
        else:
            aside = _partial_name(path, "replaced")
            os.rename(path, aside)
            os.rename(self.staging, path)
            shutil.rmtree(aside, ignore_errors=True)
        _fsync_dir(path.parent)


def relative_inside(path: Path, directory: Path) -> Path | None:
    """``path`` relative to ``directory`` if it lies inside it (``None`` otherwise)."""
    try:
        return Path(path).resolve().relative_to(Path(directory).resolve())
    except ValueError:
        return None

