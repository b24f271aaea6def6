"""Sizes of the string kernels' work arrays, and the fast path's chunk limits.

Plain Python (no numba), computed from the kernels' layout
(:mod:`synth.kernels.layout`) for the string bank
(:class:`synth.dsp.bank.StringBank`), which allocates the arrays and
writes the chunk limits into ``ipar``: the scratch of
:func:`synth.kernels.render.render_bank` (:func:`scratch_length`,
:func:`coupled_scratch`, :func:`sub_length`), the hand-over's buffer
(:func:`hand_over_buffer_length`), and the longest exact fast-path chunk
with and without an excitation running (:func:`max_fast_chunk`,
:func:`max_free_chunk`, the columns ``I_CHUNK`` and ``I_CHUNK_FREE``).
No kernel calls them.

May import: :mod:`synth.kernels.layout` only.
"""

from __future__ import annotations

from ..kernels.layout import _CW, _SCRATCH_GROUP, MAX_CPL, MAX_FREE, MAX_SUB, S_NS


def hand_over_buffer_length(max_cells: int, rows: int) -> int:
    """Samples of ``buf`` that :func:`hand_over_loop` needs for strings of
    at most ``max_cells`` cells (on the finer grid) and ``rows`` fitted
    outputs."""
    n_run = MAX_SUB * rows + MAX_SUB + 2
    return 2 * max_cells + 2 * n_run + S_NS + 3 * rows + 2 * max_cells + 2 * MAX_FREE


def coupled_scratch(max_group: int) -> int:
    """Samples at the end of ``scratch`` for coupled groups of at most
    ``max_group`` strings (a group of G uses its last (2 G + 1) _CW)."""
    return (2 * int(max_group) + 1) * _CW


def scratch_length(max_block: int, max_region: int, max_bend: int,
                   max_group: int = MAX_CPL) -> int:
    """Samples of ``scratch`` that :func:`synth.kernels.render.render_bank`
    needs for chunks of at most ``max_block`` samples, regions of at most
    ``max_region`` points, pitch-bend lines of at most ``max_bend`` samples
    and coupled groups of at most ``max_group`` strings."""
    return (_SCRATCH_GROUP + max_block + 3 * (max_block + max_region + 2 + 512) + max_bend
            + max_block + 8 + coupled_scratch(max_group))


def sub_length(max_block: int) -> int:
    """Samples per bus of the staging mix (``sub``) that
    :func:`synth.kernels.render.render_bank` needs for strings on a finer
    grid (``I_SUB`` > 1)."""
    return max_block * MAX_SUB


def max_fast_chunk(N: int, k: int, R: int, out_mode: int) -> int:
    """Longest chunk (samples) for which the fast path is exact, or 0 when it
    does not apply (excitation inside or next to the region).

    No sample may meet two operation points within one chunk: the loop
    distances region-excitation (k - R), excitation-far end (N - k) and,
    for the bridge-force pickup next to x = L, region-far end (N - R).
    """
    if R > 0 and k <= R + 1:
        return 0
    c = min(k - R, N - k, N - R) - 1
    if out_mode == 1:
        c = min(c, N - R - 2)
    return max(c, 0)


def max_free_chunk(N: int, k: int, R: int, out_mode: int, filt: bool = False) -> int:
    """Longest exact chunk with no excitation running: the excitation point
    is then no operation point, except as the pickup of ``out_mode`` 0 (u
    at k is read after the chunk's region and far-end steps).

    With the bridge-force output of a far-end filter (``filt``: the force
    comes from the filter's output, not from the ring) and no region, the
    far end is the only operation point: a sample it writes comes back to
    it after the loop's 2N steps, so a chunk may take 2N - 2 (its C + 1
    arriving samples and the previous output are C + 2 distinct slots),
    where the region's distance bounds it at N - R - 2."""
    if out_mode == 0:
        if R > 0 and k <= R + 1:
            return 0
        c = min(k - R, N - k, N - R) - 1
    elif filt and R == 0:
        c = 2 * N - 2
    else:
        c = N - R - 2
    return max(c, 0)
