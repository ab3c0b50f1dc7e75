"""JAX's persistent compilation cache for tofjax's commands, scripts and notebooks: where it is and
how it is turned on (:func:`enable_compilation_cache`, public as ``tofjax.enable_compilation_cache``).
Imports nothing heavy: the ``tofjax`` command reads it before JAX starts."""

from __future__ import annotations

import os
import sys

#: Environment variable that moves (a directory) or disables ("off", "0", "") the compilation cache.
CACHE_ENV = "TOFJAX_CACHE_DIR"


def compilation_cache_dir() -> str | None:
    """Where the CLI keeps compiled programs: ``$TOFJAX_CACHE_DIR``; else an existing
    ``$JAX_COMPILATION_CACHE_DIR``; else ``$XDG_CACHE_HOME/tofjax/jax`` (``~/.cache/tofjax/jax``).
    ``None`` when ``TOFJAX_CACHE_DIR`` is ``off``, ``0``, ``false`` or empty."""
    chosen = os.environ.get(CACHE_ENV)
    if chosen is not None:
        return None if chosen.strip().lower() in ("", "0", "off", "false", "no", "none") else chosen
    if os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return os.environ["JAX_COMPILATION_CACHE_DIR"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "tofjax", "jax")


#: XLA's older CPU emitters compile the many small programs of a calibration about twice as fast
#: (cold `tofjax calibrate` of the example: 24 s -> see bench/); the commands that are
#: compile-bound ask for them before JAX starts, unless XLA_FLAGS already chooses.
FAST_COMPILE_XLA_FLAG = "--xla_cpu_use_fusion_emitters=false"


def enable_compilation_cache(fast_compile: bool = False, *, notice: bool = True) -> str | None:
    """Turn on JAX's persistent compilation cache for this process, as every ``tofjax`` command
    does: the second run of a script or notebook loads its compiled programs instead of compiling
    them again (README, "Python API"). The directory is :func:`compilation_cache_dir`'s
    (``$TOFJAX_CACHE_DIR``, else ``$JAX_COMPILATION_CACHE_DIR``, else ``~/.cache/tofjax/jax``;
    ``TOFJAX_CACHE_DIR=off`` turns it off); every program is kept, the small ones too (a warm calibration
    compiled 40 small programs again in 0.6 s, and loads them in 0.3 s).
    ``fast_compile``: also ask XLA for its faster-compiling CPU emitters
    (:data:`FAST_COMPILE_XLA_FLAG`; only before JAX has started). ``notice``: say ``compiling (first
    run; cached for next time) ...`` on standard error once, when this process has compiled for 2 s,
    as the commands do (:func:`tofjax.progress.compile_notice`; the commands say it themselves, and
    ``--quiet`` silences it). Returns the directory (or ``None``). Call it once, before the first
    computation."""
    flags = os.environ.get("XLA_FLAGS", "")
    if fast_compile and "jax" not in sys.modules and "fusion_emitters" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} {FAST_COMPILE_XLA_FLAG}".strip()
    if notice:
        from .progress import compile_notice

        compile_notice()
    path = compilation_cache_dir()
    if path is None:
        return None
    import jax

    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    return path
