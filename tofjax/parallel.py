"""Running on several devices, public (docs/model.md, "Full frames").

- :func:`sharded_map` (a function mapped over a batch split across the devices, compiled once).
"""

from ._frame import sharded_map

__all__ = ["sharded_map"]
