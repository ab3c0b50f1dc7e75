"""How much memory a run may use, and what a frame's run needs: sizes are refused before any work
with the limit named, never found out by running out of memory half-way (README, "Outputs")."""

from __future__ import annotations

import functools
import os
import resource


def available_memory_bytes() -> int:
    """The memory this process may still take: the smaller of the system's available memory
    (``MemAvailable``, else the physical memory) and what the address-space limit (``ulimit -v``)
    leaves beside what the process has mapped already."""
    limits = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    limits.append(int(line.split()[1]) * 1024)
    except OSError:
        pass
    physical, address_space = _physical_bytes(), _address_space_limit()
    if not limits and physical is not None:
        limits.append(physical)
    if address_space is not None:
        mapped = 0
        try:
            with open("/proc/self/status", encoding="ascii") as fh:
                for line in fh:
                    if line.startswith("VmSize:"):
                        mapped = int(line.split()[1]) * 1024
        except OSError:
            pass
        limits.append(address_space - mapped)
    return max(min(limits), 0) if limits else 1 << 62


@functools.cache
def device_memory_bytes() -> int:
    """The memory of the default JAX device, once per process: an accelerator's as JAX reports it
    (``memory_stats()["bytes_limit"]``, what its allocator may take: 75 % of the card by default),
    a CPU's (or a device's that does not report it) the machine's physical memory within ``ulimit -v``
    (16 GiB where neither is known).
    What the frames' chunks (:func:`tofjax._executor.frame_chunk_elements`) and the frames a call
    returns (:func:`kept_bytes_limit`) are sized by."""
    import jax

    device = jax.devices()[0]
    try:
        stats = device.memory_stats() if device.platform != "cpu" else None
    except Exception:  # noqa: BLE001 - a backend that cannot say: the machine's memory bounds it
        stats = None
    if stats and stats.get("bytes_limit"):
        return int(stats["bytes_limit"])
    limits = [x for x in (_physical_bytes(), _address_space_limit()) if x is not None]
    return min(limits) if limits else 1 << 34


def _physical_bytes() -> int | None:
    """The machine's physical memory, or ``None`` where the system does not say."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _address_space_limit() -> int | None:
    """This process's address-space limit (``ulimit -v``), or ``None`` where there is none."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return None if soft == resource.RLIM_INFINITY else soft


#: The share of the device's memory the frames one call returns may take (:func:`kept_bytes_limit`).
KEPT_SHARE = 4


def kept_bytes_limit() -> int:
    """The most memory the frames one call returns may take (``keep_frames`` of a sweep or a frame,
    :meth:`tofjax.PreparedFrame.sample`'s frames): a quarter of the device's memory
    (:func:`device_memory_bytes`), so that the chunks that draw them and the caller's own arrays
    fit beside them."""
    return device_memory_bytes() // KEPT_SHARE


def kept_limit_text() -> str:
    """The limit of :func:`kept_bytes_limit` in words, for refusals."""
    return f"frames returned take at most a quarter of this device's {size_text(device_memory_bytes())}"


def frame_memory_bytes(pixels: int, subpixel_samples: int, returns_per_pixel: int, patches: int = 0,
                       columns: int = 0, two_bounce_bins: int = 32) -> int:
    """An upper estimate of the memory a frame's ray cast, exposure and frames need beyond the
    process's own (bench: a 1280 x 960 wall at 3 x 3 rays per pixel peaked 1.7 kB a pixel above a
    640 x 480 one; a 1280 x 960 corner at one ray per pixel at 3.0 GB in all): per pixel 700 bytes
    of results, 200 bytes per sub-pixel ray and 16 per return; a scene with ``patches`` (two-bounce
    light) adds one image row's patch-by-bin table, ``columns`` x ``patches`` x ``bins`` x 24 bytes."""
    per_pixel = 700 + 200 * subpixel_samples**2 + 16 * returns_per_pixel
    return pixels * per_pixel + columns * patches * two_bounce_bins * 24


def size_text(n: float) -> str:
    """Bytes in words: ``11.2 GB``."""
    for unit in ("bytes", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} TB"  # pragma: no cover
