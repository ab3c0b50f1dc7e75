"""The tabulated data of ``tofjax/data/`` (provenance in each file's header), read once: a module of no
other of tofjax's, so that the configuration's checks (:mod:`tofjax._schema`) may read a table too."""

from __future__ import annotations

import functools
from importlib import resources

import numpy as np


def read_table(name: str) -> tuple[np.ndarray, np.ndarray]:
    """A two-column table of ``tofjax/data/``: (wavelength in m, value)."""
    text = resources.files("tofjax").joinpath("data", name).read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if line and not line.startswith("#")][1:]
    data = np.array([[float(x) for x in row.split(",")] for row in rows])
    return data[:, 0] * 1e-9, data[:, 1]


@functools.cache
def silicon_absorption_per_m() -> tuple[np.ndarray, np.ndarray]:
    """Crystalline silicon's absorption coefficient at 300 K, alpha = 4 pi k / lambda (1/m), on its
    table's wavelengths (m; M. A. Green, Sol. Energy Mater. Sol. Cells 92, 1305 (2008),
    ``silicon_green2008.csv``)."""
    wavelength_m, k = read_table("silicon_green2008.csv")
    return wavelength_m, 4.0 * np.pi * k / wavelength_m
