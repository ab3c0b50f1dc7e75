"""The tofjax-sweep CSV format: the contract between simulating, recording and calibrating.

Layout (UTF-8)::

    # format: tofjax-sweep/1
    # sweep: distance
    # source: simulation
    # modulation_frequency_hz: 80320000.0
    # n_phases: 4
    # created_utc: 2026-11-21T09:00:00+00:00
    # ... more "# key: value" metadata lines ...
    distance_m,integration_time_s,illuminance_lx,n_frames,depth_mean_m,depth_std_m,...
    0.45,0.002,20.0,2000,0.4454,0.0021,...

- The first line names the format and its version; a reader refuses versions it does not know.
  This reader reads versions 1 to 4; writers write the oldest version that holds the file
  (:func:`needed_format`).
- Version 2 (a backward-compatible addition: every version-1 file is a valid version-2 file in
  meaning) allows what a version-1 reader would misread, so such files say ``tofjax-sweep/2``:
  - observable columns may be absent: a depth-only file (published depth-noise data) has no
    amplitude columns, an amplitude-only file no depth columns; at least one of ``depth_std_m``,
    ``depth_mean_m`` and ``amplitude_mean_lsb`` is present, and ``valid_fraction`` may be absent
    (unknown). Absent columns read as empty (NaN) columns;
  - ``modulation_frequencies_hz: f1, f2, ...``: every modulation frequency of the measurement (the
    first equals ``modulation_frequency_hz``); the depth columns are then the camera's fused,
    unwrapped distance, the amplitude columns those of the first frequency;
  - ``frequency_fusion``: how the camera combined them (:data:`FUSIONS`; default
    ``inverse_variance``);
  - ``integration_time_per``: what ``integration_time_s`` counts, ``phase_image`` (default, the
    model's unit), ``frequency`` (all phase images of one frequency) or ``frame`` (all of a frame).
- Version 3 (again backward-compatible) adds the sensor's temperature as an operating-point
  quantity:
  - an optional column ``temperature_c``: the sensor's temperature at each row, °C (a reader of
    version 2 would ignore it and take the configured one); absent, every row is at the model's
    ``pixel.temperature_c``;
  - ``sweep: temperature``: a sweep of the sensor's temperature, whose file must have the column.
- Version 4 adds **bounds**: what a datasheet promises rather than what was measured ("temporal
  noise < 1 mm up to 5.5 m at 90 % reflectivity"). A bound column is named
  ``<quantity>_<relation>`` (:func:`bound_column`): the quantity is ``depth_std_m`` (temporal depth
  noise), ``depth_error_m`` (the systematic error's magnitude, ``|mean depth - distance|``) or
  ``amplitude_mean_lsb``; the relation ``le`` (<=), ``lt`` (<), ``ge`` (>=) or ``gt`` (>). Each cell
  is the bound at that row's operating point (a bound stated relative to the distance, "<= 1 % of
  the distance", is written out per row; an empty cell: no bound at that row), so that ranges
  ("over 0.5-4 m") are the rows the file has. Every bound column needs a metadata line
  ``# bound.<column>: ...`` quoting the statement and naming its document; every such line names a
  bound column the file has, and every bound column has a value at some row (a bound that is
  stated is checked). A ``source: specification`` file has no column but the operating point,
  ``n_frames``, the measured quantities (:data:`SPECIFICATION_COLUMNS`) and bounds: another name is
  a misspelt one. The conditions it was
  stated under are the file's other metadata: configuration keys (``# scene.reflectivity: 0.9``,
  ``# illumination_waveform.modulation_frequency_hz: 100000000``) and free text (``# conditions:``).
  A version-4 file may hold bounds and no measured values, and may say ``source: specification``
  (what a datasheet states: neither simulated nor measured).
- Metadata keys are lower-case identifiers; values run to the end of the line. Required:
  ``sweep`` (distance | illuminance | integration_time | temperature), ``source`` (simulation | measurement;
  specification, format 4),
  ``modulation_frequency_hz``, ``n_phases``, ``created_utc`` (ISO 8601).
- The header names the columns (each once); the required ones are :data:`REQUIRED_COLUMNS`,
  others (e.g. the simulation's noise breakdown) may follow. Cells are plain decimal numbers
  (no quoting); an empty cell means "not measured" (read as NaN). Any other non-numeric cell,
  including the text ``nan`` or ``inf``, is an error.
- ``n_frames`` is the number of frames behind the row's statistics (0: an analytic prediction);
  standard deviations are sample standard deviations (ddof = 1) over valid frames.

Errors are :class:`SweepFileError` with the file, line and column.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import math
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import IO

import numpy as np

from ._schema import EXPOSURE_DEFINITIONS, FUSIONS, OPERATING_POINT_COLUMNS, SWEEP_AXES, SWEEPS
from .outputs import sweep_format

FORMAT_NAME = "tofjax-sweep"
FORMAT_VERSION = 4
FORMAT = f"{FORMAT_NAME}/{FORMAT_VERSION}"
#: The versions this reader reads, oldest first.
FORMATS = (f"{FORMAT_NAME}/1", f"{FORMAT_NAME}/2", f"{FORMAT_NAME}/3", FORMAT)
#: Version-1 format line (what writers write when a file needs nothing of version 2).
FORMAT_V1 = FORMATS[0]
#: Version-2 format line (what writers write when a file needs version 2 but nothing of version 3).
FORMAT_V2 = FORMATS[1]
#: Version-3 format line (a temperature sweep or column, and no bound).
FORMAT_V3 = FORMATS[2]
REQUIRED_METADATA = ("sweep", "source", "modulation_frequency_hz", "n_phases", "created_utc")
REQUIRED_COLUMNS = (
    "distance_m", "integration_time_s", "illuminance_lx", "n_frames", "depth_mean_m", "depth_std_m",
    "amplitude_mean_lsb", "amplitude_std_lsb", "valid_fraction",
)
#: Columns every version-2 file has; of the other required columns of version 1, at least one of
#: :data:`OBSERVABLE_COLUMNS` is present.
REQUIRED_COLUMNS_V2 = ("distance_m", "integration_time_s", "illuminance_lx", "n_frames")
OBSERVABLE_COLUMNS = ("depth_std_m", "depth_mean_m", "amplitude_mean_lsb")
#: Metadata a version-1 file may not carry (a version-1 reader would ignore it and misread the file).
V2_METADATA = ("modulation_frequencies_hz", "frequency_fusion", "integration_time_per")
#: The sweeps and columns a version-1 or -2 file may not have (such a reader would misread it).
V3_SWEEPS = ("temperature",)
V3_COLUMNS = ("temperature_c",)
#: What a bound (version 4) may bound, and its relations (column suffix -> symbol).
BOUND_QUANTITIES = ("depth_std_m", "depth_error_m", "amplitude_mean_lsb")
BOUND_RELATIONS = {"le": "<=", "lt": "<", "ge": ">=", "gt": ">"}
SWEEP_NAMES = SWEEPS
SOURCES = ("simulation", "measurement", "specification")
#: Sources a version-1 to -3 file may not name (a published specification: bounds, format 4).
V4_SOURCES = ("specification",)
_KEY = re.compile(r"[a-z][a-z0-9_.]*\Z")
_META = re.compile(r"#\s*([^:]+?)\s*:\s?(.*)\Z")


class SweepFileError(ValueError):
    """A malformed sweep file; ``path``, ``line`` and ``column`` (1-based, or None) say where."""

    def __init__(self, path, line: int | None, column: int | None, message: str):
        self.path, self.line, self.column = str(path), line, column
        where = str(path)
        if line is not None:
            where += f":{line}"
            if column is not None:
                where += f":{column}"
        super().__init__(f"{where}: {message}")


@dataclasses.dataclass
class SweepData:
    """A sweep file in memory: ``metadata`` (strings) and ``columns`` (float arrays, NaN = empty)."""

    metadata: dict[str, str]
    columns: dict[str, np.ndarray]
    path: str | None = None
    #: 1-based line number of each data row in the file.
    lines: np.ndarray | None = None
    #: Column name -> 1-based field number in the header.
    fields: dict[str, int] = dataclasses.field(default_factory=dict)

    @property
    def n_rows(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def sweep(self) -> str:
        return self.metadata["sweep"]

    @property
    def modulation_frequency_hz(self) -> float:
        return float(self.metadata["modulation_frequency_hz"])

    @property
    def n_phases(self) -> int:
        return int(self.metadata["n_phases"])

    @property
    def modulation_frequencies_hz(self) -> list[float]:
        """Every modulation frequency of the measurement (one unless the file lists several)."""
        text = self.metadata.get("modulation_frequencies_hz")
        return _frequency_list(text) if text else [self.modulation_frequency_hz]

    @property
    def frequency_fusion(self) -> str:
        return self.metadata.get("frequency_fusion", "inverse_variance")

    @property
    def integration_time_per(self) -> str:
        return self.metadata.get("integration_time_per", "phase_image")

    @property
    def version(self) -> int:
        return int(self.metadata["format"].rpartition("/")[2])

    @property
    def bounds(self) -> list[str]:
        """The file's bound columns (format 4, :func:`bound_column`), in the header's order."""
        return [c for c in self.fields if bound_column(c)]

    def measured(self, column: str) -> bool:
        """Whether the file has ``column`` with at least one value."""
        return column in self.fields and bool(np.any(~np.isnan(self.columns[column])))


def bound_column(name: str) -> tuple[str, str] | None:
    """``(quantity, relation)`` of a bound column's name (``depth_std_m_lt`` -> ``("depth_std_m",
    "lt")``), or None for any other column."""
    quantity, _, relation = name.rpartition("_")
    return (quantity, relation) if quantity in BOUND_QUANTITIES and relation in BOUND_RELATIONS else None


def _frequency_list(text: str) -> list[float]:
    return [float(part) for part in text.replace(";", ",").split(",") if part.strip()]


def _check_metadata(path, metadata: Mapping[str, str], lines: Mapping[str, int]) -> None:
    def fail(key, message):
        raise SweepFileError(path, lines.get(key), None, message)

    for key in REQUIRED_METADATA:
        if key not in metadata:
            raise SweepFileError(path, None, None, f'missing required metadata line "# {key}: ..."')
    if metadata["sweep"] not in SWEEP_NAMES:
        fail("sweep", f"sweep = {metadata['sweep']!r} is not one of {', '.join(SWEEP_NAMES)}")
    if metadata["source"] not in SOURCES:
        fail("source", f"source = {metadata['source']!r} is not one of {', '.join(SOURCES)}")
    try:
        f = float(metadata["modulation_frequency_hz"])
    except ValueError:
        f = math.nan
    if not (math.isfinite(f) and f > 0):
        fail("modulation_frequency_hz",
             f"modulation_frequency_hz = {metadata['modulation_frequency_hz']!r} is not a number > 0")
    if metadata["n_phases"] not in ("2", "3", "4", "5"):
        fail("n_phases", f"n_phases = {metadata['n_phases']!r} is not an integer 2..5")
    try:
        _dt.datetime.fromisoformat(metadata["created_utc"])
    except ValueError:
        fail("created_utc", f"created_utc = {metadata['created_utc']!r} is not an ISO 8601 time")
    if metadata.get("format") in (FORMAT_V1, FORMAT_V2, FORMAT_V3) and metadata["source"] in V4_SOURCES:
        fail("source", f"source = {metadata['source']!r} needs format {FORMAT}: write \"# format: {FORMAT}\" on the "
                       "first line")
    if metadata.get("format") in (FORMAT_V1, FORMAT_V2) and metadata["sweep"] in V3_SWEEPS:
        fail("sweep", f"sweep = {metadata['sweep']!r} needs format {FORMAT_V3}: write \"# format: {FORMAT_V3}\" on "
                      "the first line")
    if metadata.get("format") == FORMAT_V1:
        for key in V2_METADATA:
            if key in metadata:
                fail(key, f"metadata {key} needs format {FORMAT_V2} (a {FORMAT_V1} reader would ignore it): write "
                          f'"# format: {FORMAT_V2}" on the first line')
    if "modulation_frequencies_hz" in metadata:
        text = metadata["modulation_frequencies_hz"]
        try:
            freqs = _frequency_list(text)
        except ValueError:
            freqs = []
        if len(freqs) < 1 or not all(math.isfinite(x) and x > 0 for x in freqs) or len(set(freqs)) != len(freqs):
            fail("modulation_frequencies_hz", f"modulation_frequencies_hz = {text!r} is not a comma-separated list of "
                                              "distinct frequencies > 0 Hz")
        if not math.isclose(freqs[0], f, rel_tol=1e-9):
            fail("modulation_frequencies_hz", f"modulation_frequencies_hz = {text!r} must start with "
                                              f"modulation_frequency_hz = {metadata['modulation_frequency_hz']}")
    for key, allowed in (("frequency_fusion", FUSIONS), ("integration_time_per", EXPOSURE_DEFINITIONS)):
        if key in metadata and metadata[key] not in allowed:
            fail(key, f"{key} = {metadata[key]!r} is not one of {', '.join(allowed)}")


#: Operating-point columns -> the configuration key whose range they share.
_OPERATING_POINT_KEYS = {a.column: a.key for a in SWEEP_AXES.values()}


def _check_value(path, line: int, column: int, name: str, x: float) -> None:
    def fail(allowed):
        raise SweepFileError(path, line, column, f"column {name} = {x!r} is out of range: allowed {allowed}")

    if name == "n_frames" and not (x >= 0 and float(x).is_integer()):
        fail("an integer >= 0")
    if name == "valid_fraction" and not 0.0 <= x <= 1.0:
        fail("0 <= value <= 1")
    if ("_std_" in name or name.endswith("_std")) and x < 0:
        fail("value >= 0 (a standard deviation)")
    if name in _OPERATING_POINT_KEYS:
        from ._schema import KEY_BY_DOTTED, in_range

        key = KEY_BY_DOTTED[_OPERATING_POINT_KEYS[name]]
        if not in_range(key, x):
            fail(f"{key.range_text()} [{key.unit}], as {key.dotted}")
    if name == "amplitude_mean_lsb" and x < 0:
        fail("value >= 0 (an amplitude)")
    if bound_column(name) and x < 0:
        fail("value >= 0 (a bound on a noise, an error's magnitude or an amplitude)")


def parse_sweep(text: str, path: str | os.PathLike = "<string>", *, allow_empty: bool = False) -> SweepData:
    """Parse the text of a sweep file (see the module docstring for the format). ``allow_empty``
    accepts a file with a header and no rows yet (a recording that has just started)."""
    lines = text.splitlines()
    version = sweep_format(lines[0]) if lines else None  # the pattern rule 3 recognises a measurement by
    if version not in FORMATS:
        if version is not None and version.startswith(FORMAT_NAME + "/"):
            raise SweepFileError(path, 1, 1, f"unsupported format version {version!r}: this tofjax reads "
                                             + " and ".join(FORMATS))
        raise SweepFileError(path, 1, 1, f'not a tofjax sweep file: the first line must be "# format: {FORMAT}" '
                                         f'(or "{FORMAT_V1}")')
    metadata: dict[str, str] = {"format": version}
    meta_lines: dict[str, int] = {"format": 1}
    i = 1
    while i < len(lines) and lines[i].startswith("#"):
        match = _META.match(lines[i].strip())
        if not match or not _KEY.match(match.group(1)):
            raise SweepFileError(path, i + 1, 1, f'malformed metadata line {lines[i]!r}: expected "# key: value" '
                                                 "with a lower-case key")
        key = match.group(1)
        if key in metadata:
            raise SweepFileError(path, i + 1, 1, f"metadata key {key!r} repeats line {meta_lines[key]}")
        metadata[key], meta_lines[key] = match.group(2).strip(), i + 1
        i += 1
    _check_metadata(path, metadata, meta_lines)
    if i >= len(lines) or not lines[i].strip():
        raise SweepFileError(path, i + 1, 1, "missing header row after the metadata")
    header_line = i + 1
    header = [h.strip() for h in lines[i].split(",")]
    if any(_looks_numeric(h) for h in header):
        raise SweepFileError(path, header_line, 1, "missing header row: after the metadata the first line must name "
                                                   "the columns (" + ",".join(REQUIRED_COLUMNS[:3]) + ",...), but "
                                                   f"this line holds numbers ({lines[i][:40]!r})")
    for j, name in enumerate(header):
        if not _KEY.match(name):
            raise SweepFileError(path, header_line, _column(lines[i], j), f"bad column name {name!r}")
        if name in header[:j]:
            raise SweepFileError(path, header_line, _column(lines[i], j), f"column {name!r} appears twice")
    missing = [c for c in (REQUIRED_COLUMNS if version == FORMAT_V1 else REQUIRED_COLUMNS_V2) if c not in header]
    if missing:
        more = (f" (format {FORMAT_V2} allows a file without the amplitude or the depth columns)"
                if version == FORMAT_V1 and any(c not in REQUIRED_COLUMNS_V2 for c in missing) else "")
        raise SweepFileError(path, header_line, None, "missing required column(s): " + ", ".join(missing) + more)
    for j, name in enumerate(header):
        needs = FORMAT if bound_column(name) else FORMAT_V3 if name in V3_COLUMNS else None
        if needs and FORMATS.index(version) < FORMATS.index(needs):
            raise SweepFileError(path, header_line, _column(lines[i], j),
                                 f"column {name} needs format {needs} (a {version} reader would ignore it): write "
                                 f'"# format: {needs}" on the first line')
        if bound_column(name) and not metadata.get(f"bound.{name}"):
            raise SweepFileError(path, header_line, _column(lines[i], j),
                                 f'bound column {name} needs its source: a metadata line "# bound.{name}: ..." quoting '
                                 "the statement and naming its document")
    _check_bound_names(path, metadata, meta_lines, lines, header, header_line)
    axis_column = SWEEP_AXES[metadata["sweep"]].column
    if axis_column not in header:
        raise SweepFileError(path, header_line, None, f"missing required column {axis_column}: the file's sweep is "
                                                      f"{metadata['sweep']}")
    if not any(c in header for c in OBSERVABLE_COLUMNS) and not any(bound_column(c) for c in header):
        raise SweepFileError(path, header_line, None, "no measured quantity: the file needs at least one of the columns "
                                                      + ", ".join(OBSERVABLE_COLUMNS) + f" (or, format {FORMAT}, a bound)")
    rows: list[list[float]] = []
    row_lines: list[int] = []
    for k in range(i + 1, len(lines)):
        raw = lines[k]
        if not raw.strip():
            continue
        row_lines.append(k + 1)
        cells = raw.split(",")
        if len(cells) != len(header):
            at = _column(raw, len(header)) if len(cells) > len(header) else len(raw) + 1
            raise SweepFileError(path, k + 1, at, f"row has {len(cells)} cells, the header has {len(header)}")
        row = []
        for j, cell in enumerate(cells):
            cell = cell.strip()
            if not cell:
                row.append(math.nan)
                continue
            try:
                x = float(cell)
            except ValueError:
                x = math.nan
            if not math.isfinite(x) or cell.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                raise SweepFileError(path, k + 1, _column(raw, j),
                                     f"column {header[j]}: {cell!r} is not a finite number (leave the cell empty "
                                     "for 'not measured')")
            _check_value(path, k + 1, _column(raw, j), header[j], x)
            row.append(x)
        rows.append(row)
    if not rows and not allow_empty:
        raise SweepFileError(path, len(lines) + 1, None, "no data rows")
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    for j, name in enumerate(header):  # a stated bound is checked: it has a value at some row
        if rows and bound_column(name) and np.all(np.isnan(data[:, j])):
            raise SweepFileError(path, header_line, _column(lines[header_line - 1], j),
                                 f"bound column {name} has no value in any row: a bound is checked at the rows that "
                                 f"give it (an empty cell: no bound at that row); give its values, or remove the column "
                                 f"and its bound.{name} line")
    columns = {name: data[:, j] for j, name in enumerate(header)}
    for name in REQUIRED_COLUMNS:  # absent (version 2): not measured
        columns.setdefault(name, np.full(len(rows), np.nan))
    return SweepData(metadata, columns, str(path), np.array(row_lines), {name: j + 1 for j, name in enumerate(header)})


#: The columns a specification (``source: specification``, format 4) may have besides its bounds:
#: the operating point, the frames and the observables (what a comparison reads). Any other column
#: of a specification is refused: nothing would read it, so it is a misspelt bound or quantity.
SPECIFICATION_COLUMNS = (*REQUIRED_COLUMNS, *V3_COLUMNS)
#: Every name a bound column may have (:func:`bound_column`).
BOUND_COLUMNS = tuple(f"{q}_{r}" for q in BOUND_QUANTITIES for r in BOUND_RELATIONS)
_BOUND_FORM = (f"a bound column is named <quantity>_<relation> (quantity {', '.join(BOUND_QUANTITIES)}; relation "
               f"{', '.join(BOUND_RELATIONS)})")


#: Relations as other notations spell them (``depth_std_m_lte``) -> this format's.
_RELATION_ALIASES = {"lte": "le", "leq": "le", "max": "le", "gte": "ge", "geq": "ge", "min": "ge"}


def _did_you_mean(name: str, names) -> str:
    import difflib

    quantity, _, relation = name.rpartition("_")
    if quantity in BOUND_QUANTITIES and relation in _RELATION_ALIASES:
        return f' (did you mean "{quantity}_{_RELATION_ALIASES[relation]}"?)'
    close = difflib.get_close_matches(name, list(names), n=1, cutoff=0.6)
    return f' (did you mean "{close[0]}"?)' if close else ""


def _check_bound_names(path, metadata: Mapping[str, str], meta_lines: Mapping[str, int], lines: list[str],
                       header: list[str], header_line: int) -> None:
    """Every bound a file states is one it checks: each ``# bound.<column>:`` line names a bound
    column (:func:`bound_column`) that the header has, and a specification has no column that is
    neither a bound nor one of :data:`SPECIFICATION_COLUMNS` (a mistyped bound, ``depth_std_m_lte``
    or ``depth_noise_m_le``, was read as an unknown column and checked nowhere)."""
    header_text = lines[header_line - 1]
    for key in sorted((k for k in metadata if k.startswith("bound.")), key=lambda k: meta_lines[k]):
        name, line = key.removeprefix("bound."), meta_lines[key]
        where = lines[line - 1].find("bound.") + 1
        if not bound_column(name):
            if name in header:
                raise SweepFileError(path, header_line, _column(header_text, header.index(name)),
                                     f"column {name} has a bound statement (line {line}) but is not a bound: "
                                     f"{_BOUND_FORM}{_did_you_mean(name, BOUND_COLUMNS)}")
            raise SweepFileError(path, line, where, f"metadata {key} names no bound column: "
                                                    f"{_BOUND_FORM}{_did_you_mean(name, BOUND_COLUMNS)}")
        if name not in header:
            raise SweepFileError(path, line, where, f"metadata {key} states a bound, but the header (line {header_line}) "
                                                    f"has no column {name}: add the column with the bound at each row "
                                                    "it applies to, or remove the line")
    if metadata.get("source") == "specification":
        for j, name in enumerate(header):
            if name not in SPECIFICATION_COLUMNS and not bound_column(name):
                raise SweepFileError(path, header_line, _column(header_text, j),
                                     f"column {name} is neither a bound nor a column of a specification (allowed "
                                     f"{', '.join(SPECIFICATION_COLUMNS)}, and bounds): {_BOUND_FORM}"
                                     f"{_did_you_mean(name, BOUND_COLUMNS + SPECIFICATION_COLUMNS)}")


def _looks_numeric(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _column(line: str, field: int) -> int:
    """1-based character column where CSV field ``field`` (0-based) starts."""
    cells = line.split(",")
    return 1 + sum(len(c) + 1 for c in cells[: max(field, 0)])


def read_sweep(path: str | os.PathLike, *, allow_empty: bool = False) -> SweepData:
    """Read a sweep file; raises :class:`SweepFileError` naming file, line and column."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise SweepFileError(path, None, None, "file not found") from None
    except IsADirectoryError:
        raise SweepFileError(path, None, None, "is a directory, not a sweep file (give the CSV files in it, e.g. "
                                               "DIR/*.csv)") from None
    except OSError as err:
        raise SweepFileError(path, None, None, f"cannot read: {err.strerror or err}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        head = data[: err.start]
        raise SweepFileError(path, head.count(b"\n") + 1, err.start - (head.rfind(b"\n") + 1) + 1,
                             f"not a text file: byte 0x{data[err.start]:02x} is not UTF-8") from None
    return parse_sweep(text.removeprefix("\ufeff"), path, allow_empty=allow_empty)  # a byte-order mark is fine


def _format_cell(x) -> str:
    x = float(x)
    return "" if math.isnan(x) else repr(x)


def utc_now() -> str:
    """The current time as ISO 8601 UTC, to the second."""
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


class SweepWriter:
    """Write a sweep file row by row; every row is flushed and fsynced as it is written, so an
    interrupted run leaves a valid file holding every completed row (what ``tofjax record`` needs).
    The file is created whole, header included, under a temporary name and renamed into place
    (:mod:`tofjax.outputs`), so it never exists without its header.

    **Arguments:**
    - ``path``: the file to create.
    - ``metadata``: the ``# key: value`` lines (``format`` is added; ``created_utc`` defaults to now).
    - ``columns``: the column names, in order; must include :data:`REQUIRED_COLUMNS`.
    - ``sync``: fsync after every row (default); ``False`` syncs once, on close.
    - ``append``: continue an existing file (same columns) instead of creating it; its metadata
      stays as it is.
    - ``replace``: an existing file at ``path`` may be replaced (default); ``False`` refuses one
      that appears while the header is written (:class:`tofjax.outputs.OutputError`).
    - ``replace_measurement``: a measurement file may be replaced too (otherwise refused:
      :class:`tofjax.outputs.OutputError`).
    - ``atomic``: create the file under a temporary name (default); ``False`` writes ``path``
      directly, for a caller that writes the whole file under a temporary name itself
      (:func:`write_sweep`).
    """

    def __init__(self, path: str | os.PathLike, metadata: Mapping[str, object], columns: Iterable[str],
                 *, sync: bool = True, append: bool = False, replace: bool = True, replace_measurement: bool = False,
                 atomic: bool = True):
        from .outputs import atomic_path

        self.path = Path(path)
        self.sync = sync
        self.columns = list(columns)
        meta = {k: str(v) for k, v in metadata.items() if k != "format"}
        meta = {"format": needed_format(meta, self.columns), **meta}
        meta.setdefault("created_utc", utc_now())
        for key, value in meta.items():
            if not _KEY.match(key) or "\n" in value:
                raise ValueError(f"metadata {key!r}: {value!r}: keys must be lower-case identifiers, values one line")
        missing_meta = [k for k in REQUIRED_METADATA if k not in meta]
        missing = [c for c in REQUIRED_COLUMNS_V2 if c not in self.columns]
        if not any(c in self.columns for c in OBSERVABLE_COLUMNS) and not any(bound_column(c) for c in self.columns):
            missing.append(" or ".join(OBSERVABLE_COLUMNS) + " (or a bound)")
        if missing_meta or missing:
            raise ValueError(f"sweep file {self.path}: missing metadata {missing_meta} / columns {missing}")
        _check_metadata(self.path, meta, {})
        if append:
            existing = read_sweep(self.path, allow_empty=True)
            if list(existing.columns) != self.columns:
                raise SweepFileError(self.path, None, None, f"cannot append: the file's columns {list(existing.columns)}"
                                                            f" differ from {self.columns}")
        else:
            header = "".join(f"# {k}: {v}\n" for k, v in meta.items()) + ",".join(self.columns) + "\n"
            with (atomic_path(self.path, replace=replace, replace_measurement=replace_measurement) if atomic
                  else contextlib.nullcontext(self.path)) as target:
                Path(target).write_text(header, encoding="utf-8", newline="\n")
        self._file: IO[str] | None = open(self.path, "a", encoding="utf-8", newline="\n")

    def _write(self, text: str) -> None:
        assert self._file is not None, "SweepWriter is closed"
        self._file.write(text)
        self._file.flush()
        if self.sync:
            os.fsync(self._file.fileno())

    def write_row(self, row: Mapping[str, float]) -> None:
        """Append one row (missing or NaN values become empty cells)."""
        unknown = set(row) - set(self.columns)
        if unknown:
            raise ValueError(f"unknown column(s) {sorted(unknown)} for sweep file {self.path}")
        self._write(",".join(_format_cell(row.get(c, math.nan)) for c in self.columns) + "\n")

    def write_rows(self, columns: Mapping[str, np.ndarray], n: int, block: int = 4096) -> None:
        """Append ``n`` rows from column arrays (rows as :meth:`write_row` formats them), ``block``
        rows per write, so that the text of a million rows is never held at once."""
        unknown = set(columns) - set(self.columns)
        if unknown:
            raise ValueError(f"unknown column(s) {sorted(unknown)} for sweep file {self.path}")
        empty = np.full(n, math.nan)
        arrays = [np.asarray(columns.get(c, empty), dtype=float) for c in self.columns]
        for start in range(0, n, block):
            cells = [[_format_cell(x) for x in a[start:start + block].tolist()] for a in arrays]
            self._write("".join(",".join(row) + "\n" for row in zip(*cells, strict=True)))

    def close(self) -> None:
        if self._file is not None:
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()
            self._file = None

    def __enter__(self) -> SweepWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def needed_format(metadata: Mapping[str, str], columns: Iterable[str]) -> str:
    """The oldest format that holds a file: version 4 for a bound, version 3 for a temperature sweep
    or column, else version 1 unless it lacks a version-1 column or names version-2 metadata (an older
    reader must refuse such a file, not misread it)."""
    columns = list(columns)
    if any(bound_column(c) for c in columns) or metadata.get("source") in V4_SOURCES:
        return FORMAT
    if metadata.get("sweep") in V3_SWEEPS or any(c in columns for c in V3_COLUMNS):
        return FORMAT_V3 if metadata.get("source") not in V4_SOURCES else FORMAT
    if any(c not in columns for c in REQUIRED_COLUMNS) or any(k in metadata for k in V2_METADATA):
        return FORMAT_V2
    return FORMAT_V1


def write_sweep(path: str | os.PathLike, metadata: Mapping[str, object], columns: Mapping[str, Iterable[float]], *,
                replace: bool = True, replace_measurement: bool = False) -> Path:
    """Write a whole sweep file from column arrays of equal length, under a temporary name renamed
    into place when complete (:mod:`tofjax.outputs`: a killed run leaves the previous file or the
    new one, never a shorter file). ``replace``: an existing file may be replaced (default; a
    command passes its ``--overwrite``); ``replace_measurement``: a measurement file too (otherwise
    :class:`tofjax.outputs.OutputError`). Returns ``path``."""
    from .outputs import atomic_path

    arrays = {name: np.asarray(values, dtype=float).reshape(-1) for name, values in columns.items()}
    lengths = {len(a) for a in arrays.values()}
    if len(lengths) != 1:
        raise ValueError(f"columns have different lengths: { {k: len(a) for k, a in arrays.items()} }")
    n = lengths.pop()
    with atomic_path(path, replace=replace, replace_measurement=replace_measurement) as tmp:
        with SweepWriter(tmp, metadata, arrays, sync=False, atomic=False) as writer:
            writer.write_rows(arrays, n)
    return Path(path)


#: Columns a simulation writes beyond the required ones (the noise breakdown and flags): these, then
#: ``noise_<source>_e`` for every source of the noise budget (:data:`tofjax.chain.NOISE_SOURCES`: reset, hold,
#: photon_shot, dark_shot, readout), then :data:`SIMULATION_TAIL_COLUMNS`.
SIMULATION_COLUMNS = ("depth_unwrapped_mean_m", "snr_db", "intensity_e", "signal_e", "background_e", "dark_e")
SIMULATION_TAIL_COLUMNS = (
    "noise_read_e", "noise_quantization_e", "noise_total_e", "pixel_saturated_fraction", "adc_saturated_fraction",
    "sbi_active_fraction",
)


def operating_point_columns(result, index=()) -> dict[str, np.ndarray]:
    """The operating point's columns of a :class:`tofjax.Result` (``result``'s fields at ``index``: a
    multi-frequency run's first frequency), in the file's order: distance, integration time,
    illuminance, and the temperature for a temperature sweep (version 3; other files leave it to the
    configured ``pixel.temperature_c``, so that they stay readable by older readers)."""
    names = [c for c in REQUIRED_COLUMNS_V2 if c in OPERATING_POINT_COLUMNS]
    names += list(V3_COLUMNS) if result.sweep_variable in V3_SWEEPS else []
    return {name: np.asarray(getattr(result, name))[index] for name in names}


def columns_from_result(result) -> dict[str, np.ndarray]:
    """The sweep-file columns of a :class:`tofjax.Result` (required columns first; an analytic
    result adds ``analytic_caveats``, the bits of :data:`tofjax.schema.CAVEATS`)."""
    n = result.noise
    frames = np.full(np.shape(result.distance_m), result.n_frames, dtype=float)
    cols = {
        **operating_point_columns(result), "n_frames": frames, "depth_mean_m": result.depth_mean_m,
        "depth_std_m": result.depth_std_m, "amplitude_mean_lsb": result.amplitude_mean_lsb,
        "amplitude_std_lsb": result.amplitude_std_lsb, "valid_fraction": result.valid_fraction,
        "depth_unwrapped_mean_m": result.depth_unwrapped_mean_m, "snr_db": result.snr_db,
        "intensity_e": result.intensity_e, "signal_e": n.signal_e, "background_e": n.background_e,
        "dark_e": n.dark_e,
        **{f"noise_{name}_e": value for name, value in n.source_items()},
        "noise_read_e": n.read_e, "noise_quantization_e": n.quantization_e, "noise_total_e": n.total_e,
        "pixel_saturated_fraction": result.pixel_saturated_fraction,
        "adc_saturated_fraction": result.adc_saturated_fraction, "sbi_active_fraction": result.sbi_active_fraction,
    }
    if result.caveats is not None:
        cols["analytic_caveats"] = result.caveats
    return {k: np.asarray(v, dtype=float).reshape(-1) for k, v in cols.items()}
