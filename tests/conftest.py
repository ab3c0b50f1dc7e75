"""Test configuration: float64 (tofjax turns it on), no implicit rank promotion and strict dtype
promotion (a float32 or integer array never silently widens), one persistent compilation cache for
the run's processes. NaN checks stay off so that the tests see what a user sees."""

import ctypes.util
import os
import sys
import tempfile

# One persistent JAX compilation cache for a test run's processes: the pytest-xdist workers and the
# notebooks' kernels (which inherit the environment) compile many of the same programs. Set before
# jax is imported; a user's own setting wins.
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", os.path.join(tempfile.gettempdir(), f"tofjax-tests-jax-cache-{os.getuid()}"))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.1")
# The suite runs many small programs once: XLA's older CPU emitters compile them about twice as fast,
# and at optimisation level 0 faster still; the suite's programs run too briefly for the slower code
# to matter (the whole suite: 5.7 min instead of 6.9 on a 2-core machine). LLVM's code generation in
# one piece, not split across threads: the two workers already keep both cores busy, and the split's
# threads only compete with them (test_compare, _frame, _analytic and _processing, cold, two workers:
# 80-85 s instead of 89-91 s). The same computation, up to the last bit's rounding. The notebooks'
# kernels inherit this environment.
os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " --xla_cpu_use_fusion_emitters=false"
                           " --xla_backend_optimization_level=0 --xla_cpu_parallel_codegen_split_count=1").strip()

# The processes this one starts (the pytest-xdist workers, and through them the notebooks' kernel and
# the commands run as subprocesses) allocate with jemalloc where it is installed (Debian's libjemalloc2;
# .ci/run installs it): XLA's compiler, most of the suite's time, allocates and frees small objects by
# the million, and glibc's malloc took 12-14 % of a worker's time (perf: _int_malloc, malloc_consolidate,
# unlink_chunk ...). test_multifrequency.py and test_analytic.py, cold, one process: 45.3-45.6 s with
# glibc's malloc, 39.3-40.9 s with jemalloc (tcmalloc and mimalloc alike; glibc's tunables 43.9-44.3 s).
# The same numbers: an allocator hands out memory, it computes nothing. Without the library, glibc's.
_JEMALLOC = ctypes.util.find_library("jemalloc") if sys.platform.startswith("linux") else None  # ld.so's LD_PRELOAD
if _JEMALLOC and _JEMALLOC not in os.environ.get("LD_PRELOAD", ""):
    os.environ["LD_PRELOAD"] = ":".join(filter(None, (os.environ.get("LD_PRELOAD"), _JEMALLOC)))

import tofjax  # noqa: E402, F401  (float64 on, before jax is imported)

import jax  # noqa: E402
import pytest  # noqa: E402
from helpers import out_of_the_collectors_way  # noqa: E402

jax.config.update("jax_numpy_rank_promotion", "raise")
jax.config.update("jax_numpy_dtype_promotion", "strict")


#: The test files that take longest (seconds of test time on a 2-core machine: README 75, notebooks
#: 64, outputs 38, frame 25, compare 21, browser 20), run first, in this order, the rest after them in
#: their usual order (pyproject.toml's --no-loadscope-reorder keeps this order): the two workers
#: then finish together.
SLOWEST_FIRST = ("test_readme.py", "test_notebooks.py", "test_outputs.py", "test_frame.py", "test_compare.py",
                 "test_browser.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(SLOWEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOWEST_FIRST)))  # stable: the rest keep their order


@pytest.fixture(autouse=True)
def _survivors_out_of_the_collectors_way():
    """After each test, what survives it moves out of the garbage collector's way
    (helpers.out_of_the_collectors_way): the full collections scanned a worker's 4 million objects 31
    times, 20-22 s of each worker's time; now 3-8 s. The workers' peak memory stays the same
    (test_compare and test_frame in one process: 2.9-3.0 GB either way)."""
    yield
    out_of_the_collectors_way()


@pytest.fixture(autouse=True)
def _the_suites_cache_threshold():
    """A command run in this process (``tofjax.cli.main``) turns the persistent cache on as a user's
    does, keeping every program (threshold 0): after each test the suite's threshold comes back, so
    the rest of the worker does not write its many small programs (3300 writes in a run instead of
    a few hundred: 20-30 s of the workers' time, for 800 hits)."""
    yield
    if jax.config.jax_persistent_cache_min_compile_time_secs != _THRESHOLD_S:
        jax.config.update("jax_persistent_cache_min_compile_time_secs", _THRESHOLD_S)


_THRESHOLD_S = float(os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"])


def pytest_configure(config):
    """Assertions are rewritten in the suite's own modules only. pytest marks every package of a
    distribution that ships a plugin for rewriting (hypothesis, anyio, jaxtyping, xdist, platformdirs,
    and dash, whose 200 modules open3d imports), and each process parsed and rewrote them all anew
    (where bytecode is not written no rewritten pyc is kept; where it is, the two workers, starting
    together, may each rewrite them before either has written one): 0.9 s of each worker's start (a
    collection, whole process: 6.7-7.1 s -> 5.8-6.1 s). Their own asserts are not the suite's checks.
    Should pytest's internals move, the suite runs as before, and test_readme.py's check of this fails."""
    try:
        from _pytest.assertion.rewrite import assertstate_key

        config.stash[assertstate_key].hook._must_rewrite.clear()
    except (ImportError, KeyError, AttributeError):  # another pytest, or --assert=plain
        pass


@pytest.fixture(scope="session")
def default_params():
    return tofjax.Params()
