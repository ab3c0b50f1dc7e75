"""How a Monte Carlo run is executed, in one place (docs/model.md, "Monte Carlo"): the chunking of a
run into blocks of operating points and chunks of frames, their padding, a scan inside one program
or a loop from the host, and progress. Physics modules hand :func:`execute` three pure pieces (a
setup that makes the chain, the points' constants and the chunk step; the step, which draws and
reduces one chunk of frames; a finish that makes the result from the sums and the kept frames) and
never ask how they are being run.

Memory. Frames are drawn in chunks of at most ``elements`` phase images (blocks of operating
points x chunks of frames); each chunk is reduced to per-point sums before the next is drawn, so a
run's memory is bounded for any number of frames. Only the first ``keep`` frames of each point are
returned whole, when asked for.

Progress. With ``progress`` and concrete inputs the chunks run from the host (:func:`drive_blocks`),
one compiled call per chunk and a :func:`tofjax.progress.tick` after each: programs without host
callbacks, which JAX's persistent compilation cache keeps, and a Ctrl-C stops the run between
chunks. Under a transformation of the caller's (no concrete values to loop over) the run is one
program (:func:`run_blocks`), whose host callbacks report the chunks.

Called directly or traced. Whether a call runs with concrete inputs or inside a ``jit``, ``vmap`` or
``grad`` of the caller's is decided here alone: :func:`padded` (a sweep padded so that sweeps of
similar length share compiled programs, only when called directly, and for a Monte Carlo only while
the padding is cheap), :func:`programs` (work split
into several compiled programs when called directly, one traced function otherwise) and the
progress fork of :func:`execute`. The physics modules hand over both ways and never ask.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from . import _jit
from .progress import chunk_done, tick

#: Phase images drawn per chunk of a sweep (about 4 MB per float64 array of the chunk).
CHUNK_ELEMENTS = 1 << 19
#: Phase images per chunk of a camera frame's Monte Carlo: a whole 640 x 480 frame of 4 phase images
#: (1.2 M) is one block. On a CPU, XLA runs the loop over several blocks (``lax.map``) 4-5x slower per
#: pixel than one block (docs/model.md, "Performance"), at no more peak memory.
FRAME_CHUNK_ELEMENTS = 1 << 21
#: Operating points per block at most (the fast/three-draw path is chosen per block).
BLOCK_POINTS = 256
#: On an accelerator a frame's chunk takes as many phase images as fit an eighth of the device's
#: memory at this many bytes each: ten times what the draw of 32 or 64 frames of 640 x 480 held at its
#: peak on an H200 (12-24 bytes of temporaries per phase image; the frames returned, 17 bytes per
#: pixel and frame, are counted apart: :func:`tofjax._limits.kept_bytes_limit`).
ACCELERATOR_BYTES_PER_ELEMENT = 8 * 32
#: The largest chunk on any device (2^28 phase images: its indices stay far inside 32 bits).
MAX_CHUNK_ELEMENTS = 1 << 28


def chunk_elements(platform: str, memory_bytes: int) -> int:
    """Phase images per chunk of a camera frame's Monte Carlo on a device of ``platform`` (JAX's
    ``"cpu"``, ``"gpu"``, ``"tpu"``) with ``memory_bytes``: :data:`FRAME_CHUNK_ELEMENTS` on a CPU,
    where one 640 x 480 frame per chunk is fastest; on an accelerator the largest power of two that
    fits an eighth of its memory at :data:`ACCELERATOR_BYTES_PER_ELEMENT` bytes each, between
    :data:`FRAME_CHUNK_ELEMENTS` and :data:`MAX_CHUNK_ELEMENTS`: a GPU runs a chunk's phase images in
    parallel, and chunks of one frame left an H200 3.4x slower per frame than a ``vmap`` over keys
    (issue 35)."""
    if platform == "cpu":
        return FRAME_CHUNK_ELEMENTS
    fits = max(memory_bytes // ACCELERATOR_BYTES_PER_ELEMENT, 1)
    return min(max(1 << (fits.bit_length() - 1), FRAME_CHUNK_ELEMENTS), MAX_CHUNK_ELEMENTS)


def frame_chunk_elements() -> int:
    """:func:`chunk_elements` of the default JAX device (its memory from
    :func:`tofjax._limits.device_memory_bytes`): what :meth:`tofjax.PreparedFrame.render` and
    ``sample`` draw per chunk."""
    from ._limits import device_memory_bytes

    return chunk_elements(jax.devices()[0].platform, device_memory_bytes())


def equal_parts(total: int, most: int) -> int:
    """The size of the fewest equal parts of at most ``most`` that cover ``total`` (the last part
    padded by less than one per part): the padding of a last block, or the uncounted frames of a last
    chunk, is work for nothing (32 frames of 224 x 172 ran as three blocks of 16384 points, 27 % of
    them padding, where three of 12843 do)."""
    return -(-total // -(-total // max(1, most)))


def chunking(points: int, phases: int, frames: int, elements: int = CHUNK_ELEMENTS,
             block_points: int = BLOCK_POINTS) -> tuple[int, int]:
    """(points per block, frames per chunk) for about ``elements`` phase images a chunk."""
    block = min(points, block_points, max(1, elements // phases))
    chunk = max(1, min(frames, elements // (block * phases)))
    if chunk == frames and block < points:  # all frames fit: take more points per block instead
        block = min(points, max(block, elements // (phases * max(frames, 1))))
    return equal_parts(points, block), equal_parts(frames, chunk)


def run_blocks(step: Callable, consts, n_points: int, frames: int, keep: int, phases: int,
               elements: int = CHUNK_ELEMENTS, block_points: int = BLOCK_POINTS, progress: bool = False):
    """Run ``step(consts_block, first_frame, n_frames, counted, record) -> (sums, record)`` over blocks
    of points and chunks of frames; return the summed ``sums`` (points axis last) and the first
    ``keep`` frames' records (points axis first), padding removed. ``elements`` and ``block_points``
    set the chunks' size (:func:`chunking`); the results do not depend on them beyond rounding.

    ``consts`` is a pytree whose leaves have the points axis last (``(..., points)``); ``record``
    tells ``step`` whether to return its frames (the first ``keep``) or ``None`` (later chunks).
    ``progress``: after every chunk, a host callback counts it (:func:`tofjax.progress.chunk_done`;
    cheap against a chunk).
    """
    block, chunk, n_blocks, n_chunks = _plan(n_points, frames, keep, phases, elements, block_points)

    def one_block(cb):
        sums = record = None
        if keep > 0:
            sums, record = _record_chunk(step, cb, keep)
        if n_chunks == 0:
            return sums, record

        def chunk_sums(first):
            return _frames_chunk(step, cb, jnp.asarray(first), chunk, frames)

        if n_chunks == 1:  # no loop: a smaller program
            more = chunk_sums(keep)
            if progress:  # one chunk per block: count blocks
                jax.debug.callback(functools.partial(chunk_done, total=n_blocks),
                                   jax.tree_util.tree_leaves(more)[0].ravel()[0])
        else:
            def body(total, i):
                total = _add(total, chunk_sums(keep + i * chunk))
                if progress:  # after this chunk's sums exist: depend on one of them
                    jax.debug.callback(functools.partial(chunk_done, total=n_blocks * n_chunks),
                                       jax.tree_util.tree_leaves(total)[0].ravel()[0])
                return total, None

            shapes = jax.eval_shape(chunk_sums, keep)
            zeros = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
            more, _ = lax.scan(jax.checkpoint(body), zeros, jnp.arange(n_chunks))
        return (more if sums is None else _add(sums, more)), record

    blocks = _split(consts, n_points, n_blocks, block)
    if n_blocks == 1:
        sums, record = jax.tree_util.tree_map(lambda x: x[None], one_block(jax.tree_util.tree_map(lambda x: x[0], blocks)))
    else:
        sums, record = lax.map(one_block, blocks)
    return _join(sums, record, n_points)


def _plan(n_points: int, frames: int, keep: int, phases: int, elements: int, block_points: int):
    """(points per block, frames per chunk, blocks, chunks after the kept frames) of a run."""
    block, chunk = chunking(n_points, phases, max(frames - keep, 1), elements, block_points)
    rest = frames - keep
    return block, chunk, -(-n_points // block), (-(-rest // chunk) if rest > 0 else 0)


def _split(consts, n_points: int, n_blocks: int, block: int):
    """Leaves ``(..., points)`` -> ``(blocks, ..., block)``, the last block padded with the last point."""
    padded = n_blocks * block

    def split(x):
        pad = jnp.concatenate([x, jnp.repeat(x[..., -1:], padded - n_points, axis=-1)], axis=-1)
        return jnp.moveaxis(pad.reshape(x.shape[:-1] + (n_blocks, block)), -2, 0)

    return jax.tree_util.tree_map(split, consts)


def _join(sums, record, n_points: int):
    """Blocks' sums ``(blocks, ..., block)`` -> ``(..., points)`` and records ``(blocks, block, ...)``
    -> ``(points, ...)``, the padding cut."""

    def join(x):
        return jnp.moveaxis(x, 0, -2).reshape(x.shape[1:-1] + (-1,))[..., :n_points]

    def join_record(x):
        return x.reshape((-1,) + x.shape[2:])[:n_points]

    return (jax.tree_util.tree_map(join, sums),
            None if record is None else jax.tree_util.tree_map(join_record, record))


def drive_blocks(step: eqx.Module, consts, n_points: int, frames: int, keep: int, phases: int,
                 elements: int = CHUNK_ELEMENTS, block_points: int = BLOCK_POINTS):
    """:func:`run_blocks` with ``progress``, driven from the host: the same blocks and chunks, summed
    in the same order (the same numbers, up to XLA rounding a reduction differently in another
    program: 2e-16 relative at the test suite's XLA settings), one compiled call per chunk and a
    :func:`tofjax.progress.tick` after each, as many as :func:`run_blocks` reports.

    Why: a program with a host callback in it is never written to JAX's persistent compilation cache,
    so with the callbacks of :func:`run_blocks` every process that reported progress compiled its
    Monte Carlo anew (``tofjax simulate`` on the defaults: 5 of its 7.4 s, every run). These
    programs have none, and are compiled once per machine. ``step`` is a pytree
    (:class:`tofjax._montecarlo.FramesStep`) so that the programs take it as an argument; under a
    transformation (no concrete values to loop over) :func:`execute` uses :func:`run_blocks`.
    """
    block, chunk, n_blocks, n_chunks = _plan(n_points, frames, keep, phases, elements, block_points)
    total = n_blocks * n_chunks  # as run_blocks counts: per chunk, or per block when each has one chunk
    blocks = _split_jit(consts, n_points, n_blocks, block)
    all_sums, all_records = [], []
    for b in range(n_blocks):
        cb = _block_jit(blocks, np.int32(b))  # NumPy scalars: an eager jnp one is a program of its own
        sums = record = None
        if keep > 0:
            sums, record = _record_jit(step, cb, keep)
        more = None
        for i in range(n_chunks):  # one program for every chunk; added as the scan adds them
            sums_i = _chunk_jit(step, cb, np.int64(keep + i * chunk), chunk, frames)  # int64, as the scan's
            more = sums_i if more is None else _add_jit(more, sums_i)
            jax.block_until_ready(more)  # the tick counts a chunk done, not dispatched
            tick(total)
        if more is not None:
            sums = more if sums is None else _add_jit(sums, more)
        all_sums.append(sums)
        all_records.append(record)
    return _stack_join_jit(all_sums, None if keep == 0 else all_records, n_points)


def _block_of(blocks, b):
    return jax.tree_util.tree_map(lambda x: x[b], blocks)


def _record_chunk(step, cb, keep):
    """The sums and records of a block's first ``keep`` frames (those returned whole)."""
    return step(cb, jnp.uint32(0), keep, jnp.ones((keep,), dtype=bool), True)


def _frames_chunk(step, cb, first, chunk, frames):
    """The sums of frames first .. first + chunk - 1 of a block (those past ``frames`` not counted)."""
    counted = (first + jnp.arange(chunk)) < frames
    return step(cb, first.astype(jnp.uint32), chunk, counted, False)[0]


def _add(a, b):
    return jax.tree_util.tree_map(jnp.add, a, b)


def _stack_join(sums, records, n_points):
    stack = lambda xs: jax.tree_util.tree_map(lambda *x: jnp.stack(x), *xs)  # noqa: E731
    return _join(stack(sums), None if records is None else stack(records), n_points)


# Compiled once each (tofjax._jit: the step's arrays traced, its choices static).
_split_jit = _jit.jit(_split)
_block_jit = _jit.jit(_block_of)
_record_jit = _jit.jit(_record_chunk)
_chunk_jit = _jit.jit(_frames_chunk)
_add_jit = _jit.jit(_add)
_stack_join_jit = _jit.jit(_stack_join)


def execute(setup: Callable, consts: Callable, finish: Callable, args: tuple, *, points: int, frames: int, keep: int,
            phases: int, elements: int = CHUNK_ELEMENTS, block_points: int = BLOCK_POINTS, progress: bool = False):
    """A Monte Carlo run: ``setup(*args) -> (carry, step)`` (``step`` the chunk step of
    :func:`run_blocks`), ``consts(*args, carry)`` the points' constants (points axis last; an
    accessor, so that constants the caller prepared are not copied by a program), the chunks of
    frames, then ``finish(*args, carry, sums, kept)``, its result. ``points``, ``frames``, ``keep``
    (frames kept whole per point), ``phases``, ``elements`` and ``block_points``: the run's size and
    its chunks' (:func:`chunking`). The three functions are module-level (static: the one program
    compiles once per argument structure, :func:`tofjax.jit`); from the host they are called as they
    are, so a setup or finish that computes is compiled by its caller (:func:`tofjax.jit`; inside the
    one program it is traced inline), one that only assembles what is there stays on the host.

    With ``progress`` and concrete ``args``, from the host chunk by chunk (:func:`drive_blocks`);
    else in one program (:func:`run_blocks`, with progress callbacks when asked). The same numbers
    either way, to XLA's rounding of a sum in another program."""
    if progress and not _jit.traced(args):
        carry, step = setup(*args)
        sums, kept = drive_blocks(step, consts(*args, carry), points, frames, keep, phases, elements, block_points)
        return finish(*args, carry, sums, kept)
    return _in_one_program(setup, consts, finish, args, points, frames, keep, phases, elements, block_points,
                           progress)


#: A Monte Carlo sweep called directly runs padded as :func:`tofjax.predict`'s does while its padded
#: points draw at most this many phase images more: about 10 ms at XLA's default settings on a CPU
#: (10 ns a phase image), where a new sweep length compiles for 1-3 s. Longer runs keep their length:
#: there the padding would cost every call more than the compile it saves once.
PADDING_PHASE_IMAGES = 1 << 20


def padded(sweep, args, phase_images_per_point: int = 0):
    """``sweep`` padded with copies of its last point (:func:`tofjax._sweep.pad_sweep`: sweeps of
    similar length share the compiled programs; the caller cuts the padding from the result) when
    called with concrete ``args`` and the padding draws at most :data:`PADDING_PHASE_IMAGES` phase
    images (``phase_images_per_point`` of each point's; 0: the analytic path, which draws none); as
    it is inside a transformation of the caller's, whose program is compiled for its shapes once
    anyway."""
    from ._sweep import pad_sweep, padded_samples

    if _jit.traced(args):
        return sweep
    if (padded_samples(sweep.samples) - sweep.samples) * phase_images_per_point > PADDING_PHASE_IMAGES:
        return sweep
    return pad_sweep(sweep)  # a sweep of another shape as it is


def programs(split: Callable, whole: Callable, args: tuple):
    """``split(*args)`` when called with concrete ``args``: the work as several compiled programs,
    because XLA on a CPU evaluates a producer again in every fusion that reads it when producer and
    consumers share a program (docs/model.md, "Performance"); ``whole(*args)`` inside a
    transformation of the caller's, where everything is one program anyway (``whole`` then writes
    out what ``split`` hands from one program to the next, if it must)."""
    return whole(*args) if _jit.traced(args) else split(*args)


@_jit.jit
def _in_one_program(setup, consts, finish, args, points, frames, keep, phases, elements, block_points, progress):
    carry, step = setup(*args)
    sums, kept = run_blocks(step, consts(*args, carry), points, frames, keep, phases, elements, block_points,
                            progress=progress)
    return finish(*args, carry, sums, kept)

