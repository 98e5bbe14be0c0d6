"""The fast path of `planar_bones.evaluate`: one compiled pass over a per-vertex layout of the binding.

Why this design (measured; docs/fast_path.md): the numpy path spends most of a frame in thousands of
small batched matrix products and in `bincount`'s scatter. A sparse product from a library (scipy)
would still need the per-frame basis and the D/d factors of eq. 13–14 computed around it, a second pass,
and a large wheel per platform and Python version. So the project compiles its own kernel,
`native/planar_bones_kernel.c`: plain C with no Python C-API, loaded with `ctypes`, so one shared library
per platform serves every Python version. `scripts/build_kernel.py` puts it in the wheel
``mpeg4_face_kernel``, cross-compiled for every platform; each platform's extension zips bundle its wheel
(Blender installs it) and set-up installs this machine's into ``.venv``. Where it is missing, does not load
or reports another ABI version, or where ``MPEG4_FACE_NO_KERNEL=1`` is set, `planar_bones.evaluate` runs its
numpy reference instead.

The layout (`build_layout`, once per binding, mode and output dtype) groups the pairs by vertex (CSR), so
the kernel writes each output vertex once, with no scatter and no atomics. A face or edge pair (every
pair in SoFFD mode) is a key (triangle, region) and four coefficients; an apex pair a key (triangle,
corner), [w, h·w, a, b] and w·D, its D/d factor being computed per pair and frame. A vertex all of whose
pairs belong to triangles that have not moved takes its result at rest (``rest_out``) without its pairs
being read (``vertex_mask`` says which triangles it has pairs with): such a triangle adds exactly nothing
(its rows are the common translation, which the weight sum takes back), and in speech most triangles stay
still while the mouth moves. A played face goes further (`Playback`, the kernel's grouped entry point): its
output array is kept from frame to frame, the vertices are grouped by the triangles they have pairs with, and
only the groups with a moved triangle are summed; a still group is written once, when it comes to rest, and
then left alone (in speech a fifth of a face's vertices, a third of its pairs, are summed per frame). Each
frame the kernel
builds every triangle's basis and adds to ``base`` (the float64 reference result at the rest control
positions, less the apex pairs' in-plane part at rest) each pair's coefficients times the change of its
rows since rest, the mean translation of the control mesh taken apart and weighted by each vertex's exact
weight sum. So a rounded coefficient only ever multiplies a motion less its translation: with float32
coefficients (float32 output, as the add-on uses) the error is about 6e-8 × |coefficient| × |motion|,
below the float32 rounding of the output on the sample faces; a float64 output uses float64
coefficients and matches the reference to rounding. Sums are float64 either way. From PARALLEL_PAIRS
pairs up a second thread helps, claiming chunks of vertices as they come, so a thread the system is slow
to run leaves its share to the caller.
"""

from __future__ import annotations

import ctypes
import functools
import importlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .inputs import DeformError
from .regions import APEX, FACE, Location, TriangleFrames, deformation_basis

ABI_VERSION = 14  # must equal PBK_ABI_VERSION in native/planar_bones_kernel.c
PACKAGE = "mpeg4_face_kernel"  # the wheel's import name; its LIBRARY is the shared library's path
DISABLE = "MPEG4_FACE_NO_KERNEL"  # "1" forces the numpy path
THREADS_VARIABLE = "MPEG4_FACE_KERNEL_THREADS"  # a thread count, overriding the choice below
THREADS = 2  # from PARALLEL_PAIRS pairs up; measured on 2 cores (docs/fast_path.md)
PARALLEL_PAIRS = 50_000  # below this (the 4k sample head has 21k) a second thread costs more than it saves
MAX_THREADS = 16  # PBK_MAX_THREADS
PLAIN_REGIONS = 4  # FACE, EDGE + 0..2: key = triangle × 4 + region
APEX_CORNERS = 3  # APEX + 0..2: key = triangle × 3 + corner

_POINTER = ctypes.c_void_p
_ARGUMENTS = [ctypes.c_int64, ctypes.c_int64, *[_POINTER] * 15, ctypes.c_int32, _POINTER]
_GROUPED_ARGUMENTS = [ctypes.c_int64, ctypes.c_int64, *[_POINTER] * 14, ctypes.c_int64, *[_POINTER] * 5]
_GROUPED_ARGUMENTS += [ctypes.c_int32, _POINTER]
GUARD_KNOTS = 17  # GUARD_KNOTS in native/lip_guard.h, lips.N_KNOTS
_GUARD_ARGUMENTS = [ctypes.c_int32, ctypes.c_int64, *[_POINTER] * 3, ctypes.c_int64, *[_POINTER] * 4, ctypes.c_int64]
_GUARD_ARGUMENTS += [*[_POINTER] * 3, ctypes.c_double, ctypes.c_int64, _POINTER, ctypes.c_int64, *[_POINTER] * 4]

_PRESS_ARGUMENTS = [ctypes.c_int32, ctypes.c_int64, _POINTER, _POINTER, ctypes.c_int64, *[_POINTER] * 4]
_PRESS_ARGUMENTS += [ctypes.c_int64, ctypes.c_int64, _POINTER, ctypes.c_double, _POINTER, ctypes.c_int64]
_PRESS_ARGUMENTS += [ctypes.c_int64, _POINTER, ctypes.c_int64, *[_POINTER] * 5]

_NEAREST_ARGUMENTS = [ctypes.c_int64, *[_POINTER] * 3, ctypes.c_int64, _POINTER, ctypes.c_int32, ctypes.c_double]
_NEAREST_ARGUMENTS += [ctypes.c_double, ctypes.c_int32, *[_POINTER] * 3]
NEAREST_TIES = 8  # room for this many ties with the k-th nearest per vertex; more, and the caller uses Python
BIND_FRAME = 48  # doubles per triangle in `bind_frames` (BIND_FRAME in native/bind_regions.h)
_LOCATE_ARGUMENTS = [ctypes.c_int64, *[_POINTER] * 7]
_COLLECT_ARGUMENTS = [ctypes.c_int64, *[_POINTER] * 4, *[ctypes.c_double] * 4, *[_POINTER] * 6]
_FOLD_FREE_ARGUMENTS = [ctypes.c_int64, *[_POINTER] * 9, ctypes.c_int32, ctypes.c_double, ctypes.c_double]
_UNFOLD_ARGUMENTS = [ctypes.c_int64, ctypes.c_int64, *[_POINTER] * 9, ctypes.c_int64, _POINTER, _POINTER]
_UNFOLD_ARGUMENTS += [ctypes.c_int32, ctypes.c_double, ctypes.c_int32, ctypes.c_int32, ctypes.c_int32, ctypes.c_double]
_UNFOLD_ARGUMENTS += [ctypes.c_int32, _POINTER, _POINTER, _POINTER]


@dataclass(frozen=True, eq=False)
class Layout:
    """A binding's pairs for the kernel, in one mode and one coefficient dtype; see the module notes."""

    dtype: type
    control_rest: np.ndarray  # (M, 3) float64
    rest_bases: np.ndarray  # (T, 7, 3) float64: each triangle's deformation basis at rest, by the kernel's own code
    triangles: np.ndarray  # (T, 3) int32
    base: np.ndarray  # (N, 4) float64: the reference at rest (less the apex in-plane part), weight sum
    plain_start: np.ndarray  # (N + 1,) int32: vertex v's face/edge pairs are plain_start[v]:plain_start[v + 1]
    plain_key: np.ndarray  # (P,) int32
    plain_coef: np.ndarray  # (P, 4)
    apex_start: np.ndarray | None  # (N + 1,) int32; the apex arrays are None in SoFFD mode
    apex_key: np.ndarray | None  # (A,) int32
    apex_coef: np.ndarray | None  # (A, 4): w, h·w, a, b
    apex_scale: np.ndarray | None  # (A,): w·D
    apex_rest: np.ndarray | None  # (A,) float64: the factor r = w·D/d at rest, from the rounded a, b and w·D
    rest_out: np.ndarray  # (N, 3) of dtype: the result at rest, for vertices whose triangles all are at rest
    vertex_mask: np.ndarray  # (N, 2) uint64: bit t % 128 set when the vertex has a pair with triangle t
    group_mask: np.ndarray  # (G, 2) uint64: the distinct rows of vertex_mask, each a group of vertices
    group_start: np.ndarray  # (G + 1,) int32: group g is group_vertex[group_start[g]:group_start[g + 1]]
    group_vertex: np.ndarray  # (N,) int32: the vertices, group by group
    vertex_group: np.ndarray  # (N,) intp: each vertex's group

    @property
    def n_vertices(self) -> int:
        return len(self.base)

    @property
    def n_pairs(self) -> int:
        return len(self.plain_key) + (0 if self.apex_key is None else len(self.apex_key))

    @functools.cached_property
    def arguments(self) -> tuple:
        """The kernel's arguments between the control points and the thread count (the arrays stay alive
        as long as the layout)."""
        arrays = (self.control_rest, self.rest_bases, self.triangles, self.base, self.plain_start, self.plain_key)
        arrays += (self.plain_coef,)
        apex = (self.apex_start, self.apex_key, self.apex_coef, self.apex_scale, self.apex_rest)
        return (
            *(array.ctypes.data for array in arrays),
            *(None if a is None else a.ctypes.data for a in apex),
            self.rest_out.ctypes.data,
            self.vertex_mask.ctypes.data,
        )


def available() -> bool:
    """True when the compiled kernel is loaded and ``MPEG4_FACE_NO_KERNEL`` does not switch it off."""
    return os.environ.get(DISABLE, "") in ("", "0") and _kernel() is not None


def library_path() -> Path | None:
    """The shared library of the installed ``mpeg4_face_kernel`` package, or None."""
    try:
        return Path(importlib.import_module(PACKAGE).LIBRARY)
    except (ImportError, AttributeError, TypeError):
        return None


def open_library(path: Path | None) -> ctypes.CDLL | None:
    """The kernel at ``path`` with its functions declared, or None if it is missing, corrupt or of another ABI."""
    if path is None:
        return None
    try:
        library = ctypes.CDLL(str(path))
        library.pbk_abi_version.restype = ctypes.c_int
        if library.pbk_abi_version() != ABI_VERSION:
            return None
        for name in ("pbk_evaluate_f32", "pbk_evaluate_f64"):
            function = getattr(library, name)
            function.argtypes = _ARGUMENTS
            function.restype = ctypes.c_int
        for name in ("pbk_evaluate_groups_f32", "pbk_evaluate_groups_f64"):
            function = getattr(library, name)
            function.argtypes = _GROUPED_ARGUMENTS
            function.restype = ctypes.c_int
        library.pbk_bases.argtypes = [ctypes.c_int64, _POINTER, _POINTER, _POINTER]
        library.pbk_bases.restype = None
        library.pbk_guard_lips.argtypes = _GUARD_ARGUMENTS
        library.pbk_guard_lips.restype = ctypes.c_int
        library.pbk_press_apart.argtypes = _PRESS_ARGUMENTS
        library.pbk_press_apart.restype = ctypes.c_int
        library.pbk_press_apart_scratch.argtypes = [ctypes.c_int64] * 4
        library.pbk_press_apart_scratch.restype = ctypes.c_int64
        library.pbk_nearest_sources.argtypes = _NEAREST_ARGUMENTS
        library.pbk_nearest_sources.restype = ctypes.c_int
        library.pbk_locate.argtypes = _LOCATE_ARGUMENTS
        library.pbk_locate.restype = None
        library.pbk_distance_bound.argtypes = [ctypes.c_int64, *[_POINTER] * 3]
        library.pbk_distance_bound.restype = None
        library.pbk_collect.argtypes = _COLLECT_ARGUMENTS
        library.pbk_collect.restype = ctypes.c_int64
        library.pbk_fold_free_sweeps.argtypes = _FOLD_FREE_ARGUMENTS
        library.pbk_fold_free_sweeps.restype = ctypes.c_int32
        library.pbk_unfold.argtypes = _UNFOLD_ARGUMENTS
        library.pbk_unfold.restype = ctypes.c_int
        library.pbk_unfold_work_bytes.argtypes = [ctypes.c_int64, ctypes.c_int64]
        library.pbk_unfold_work_bytes.restype = ctypes.c_int64
        library.pbk_turned_at.argtypes = [ctypes.c_int64, *[_POINTER] * 7]
        library.pbk_turned_at.restype = ctypes.c_int64
    except (OSError, AttributeError):
        return None
    return library


@functools.cache
def _kernel() -> ctypes.CDLL | None:
    return open_library(library_path())


def build_layout(
    *,
    mode: str,
    dtype: type,
    control_rest: np.ndarray,
    triangles: np.ndarray,
    pair_vertex: np.ndarray,
    pair_triangle: np.ndarray,
    pair_region: np.ndarray,
    pair_weight: np.ndarray,
    pair_face_local: np.ndarray,
    pair_region_local: np.ndarray,
    pair_apex_distance: np.ndarray,
    base: np.ndarray,
) -> Layout:
    """The kernel's layout of a binding (``mode`` "planar_bones" or "soffd", ``dtype`` float32 or float64);
    ``base`` (N, 3) is the reference result at ``control_rest``. Every index the kernel follows is checked
    here: a binding that fails is a `DeformError`."""
    n = len(base)
    triangles = np.asarray(triangles)
    vertex = np.asarray(pair_vertex, dtype=np.intp)
    triangle = np.asarray(pair_triangle, dtype=np.intp)
    region = np.asarray(pair_region, dtype=np.intp)
    if not (
        triangles.ndim == 2
        and triangles.shape[1] == 3
        and (triangles.size == 0 or 0 <= triangles.min() <= triangles.max() < len(control_rest))
        and (
            len(vertex) == 0
            or (
                0 <= vertex.min() <= vertex.max() < n
                and 0 <= triangle.min() <= triangle.max() < len(triangles)
                and 0 <= region.min() <= region.max() < APEX + APEX_CORNERS
            )
        )
    ):
        raise DeformError("inconsistent binding arrays")
    if n >= 2**31 or len(vertex) >= 2**31:
        raise DeformError("binding too large for the compiled kernel")
    rest_out = np.ascontiguousarray(base, dtype=dtype)
    control_rest = np.ascontiguousarray(control_rest, dtype=np.float64)
    triangles = np.ascontiguousarray(triangles, dtype=np.int32)
    rest_bases = _rest_bases(control_rest, triangles)
    weight = np.asarray(pair_weight, dtype=np.float64)
    face_local = np.asarray(pair_face_local, dtype=np.float64)
    region_local = np.asarray(pair_region_local, dtype=np.float64)
    # x, y, z of the reference at rest, and each vertex's exact weight sum less the weights of its coefficients
    # as rounded to `dtype`: the kernel adds these back for the pairs whose triangles moved (all of them in a
    # rigid motion, which so moves a vertex by exactly its weight sum times the translation)
    rounded = weight.astype(dtype).astype(np.float64)
    correction = np.bincount(vertex, weight, minlength=n) - np.bincount(vertex, rounded, minlength=n)
    base = np.concatenate([base, correction[:, None]], axis=1, dtype=np.float64)
    by_vertex = np.argsort(vertex, kind="stable")  # each vertex's pairs stay in binding order

    soffd = mode == "soffd"
    face = np.ones(len(vertex), dtype=bool) if soffd else region == FACE
    x, y, h = (np.where(face, face_local[:, k], region_local[:, k]) for k in range(3))  # (α, β, h) on a face
    plain = by_vertex if soffd else by_vertex[region[by_vertex] < APEX]
    plain_key = (triangle * PLAIN_REGIONS + (0 if soffd else region))[plain].astype(np.int32)
    plain_coef = _gathered((weight, x * weight, y * weight, h * weight), plain, dtype)  # eq. 1, eq. 12
    apex_start = apex_key = apex_coef = apex_scale = apex_rest = None
    if not soffd:  # eq. 13–14
        apex = by_vertex[region[by_vertex] >= APEX]
        apex_start = _starts(vertex[apex], n)
        apex_key = (triangle * APEX_CORNERS + region - APEX)[apex].astype(np.int32)
        apex_coef = _gathered((weight, h * weight, x, y), apex, dtype)
        apex_scale = (weight * np.asarray(pair_apex_distance, dtype=np.float64))[apex].astype(dtype)
        apex_rest = _apex_ratio(apex_coef, apex_scale, apex_key, rest_bases)
    vertex_mask = _vertex_mask(vertex, triangle, n)
    group_vertex = np.lexsort((vertex_mask[:, 1], vertex_mask[:, 0]))  # equal masks together, by vertex
    sorted_mask = vertex_mask[group_vertex]
    first = np.r_[True, np.any(sorted_mask[1:] != sorted_mask[:-1], axis=1)] if n else np.zeros(0, bool)
    group_mask = sorted_mask[first]
    vertex_group = np.empty(n, dtype=np.intp)
    vertex_group[group_vertex] = np.cumsum(first) - 1
    return Layout(
        dtype=dtype,
        control_rest=control_rest,
        rest_bases=rest_bases,
        triangles=triangles,
        base=base,
        plain_start=_starts(vertex[plain], n),
        plain_key=plain_key,
        plain_coef=plain_coef,
        apex_start=apex_start,
        apex_key=apex_key,
        apex_coef=apex_coef,
        apex_scale=apex_scale,
        apex_rest=apex_rest,
        rest_out=rest_out,
        vertex_mask=vertex_mask,
        group_mask=np.ascontiguousarray(group_mask),
        group_start=_starts(vertex_group, len(group_mask)),
        group_vertex=group_vertex.astype(np.int32),
        vertex_group=vertex_group,
    )


def _rest_bases(control_rest: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T, 7, 3) the triangles' bases at rest as the kernel computes them each frame for the moved control points
    (so a triangle's rows change by exactly 0 where its corners did not move); numpy's where there is no kernel."""
    kernel = _kernel()
    if kernel is None:
        return np.ascontiguousarray(deformation_basis(control_rest[triangles]))
    bases = np.empty((len(triangles), 7, 3))
    kernel.pbk_bases(len(triangles), control_rest.ctypes.data, triangles.ctypes.data, bases.ctypes.data)
    return bases


def _apex_ratio(coef: np.ndarray, scale: np.ndarray, key: np.ndarray, rest_bases: np.ndarray) -> np.ndarray:
    """(A,) each apex pair's r = w·D/d at rest (eq. 13-14), d = ‖a b_j + b b_{j−1}‖ from the rounded a, b and
    the rest Gram term, 0 where d = 0: the kernel takes each pair's in-plane part as its change from this."""
    edge_normals = rest_bases[:, 4:7]
    gram = np.einsum("tjk,tjk->tj", edge_normals, edge_normals[:, [2, 0, 1]]).ravel()[key]
    a, b = coef[:, 2].astype(np.float64), coef[:, 3].astype(np.float64)
    d = np.sqrt(np.maximum(a * a + b * b + 2.0 * a * b * gram, 0.0))
    return np.divide(scale.astype(np.float64), d, out=np.zeros_like(d), where=d > 0.0)


def _vertex_mask(vertex: np.ndarray, triangle: np.ndarray, n: int) -> np.ndarray:
    """(N, 2) uint64: per vertex, bit t % 128 for each triangle t it has a pair with (the kernel skips a vertex
    none of whose bits belongs to a moved triangle; beyond 128 triangles bits are shared, which only skips less)."""
    mask = np.zeros((n, 2), dtype=np.uint64)
    bit = np.left_shift(np.uint64(1), (triangle % 64).astype(np.uint64))
    np.bitwise_or.at(mask, (vertex, (triangle // 64) % 2), bit)
    return mask


def _gathered(columns: tuple[np.ndarray, ...], pairs: np.ndarray, dtype: type) -> np.ndarray:
    """(len(pairs), len(columns)) of ``dtype``: the columns' values at ``pairs``."""
    result = np.empty((len(pairs), len(columns)), dtype=dtype)
    for k, column in enumerate(columns):
        result[:, k] = column[pairs]
    return result


def _starts(vertex: np.ndarray, n: int) -> np.ndarray:
    """CSR offsets (N + 1,) int32 of pairs grouped by ``vertex`` (sorted)."""
    start = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(np.bincount(vertex, minlength=n), out=start[1:])
    return start


def thread_count(layout: Layout) -> int:
    """``MPEG4_FACE_KERNEL_THREADS`` if set to a number, else THREADS from PARALLEL_PAIRS pairs up, else 1."""
    chosen = os.environ.get(THREADS_VARIABLE, "")
    if chosen.isdigit() and int(chosen) > 0:
        return int(chosen)
    return THREADS if layout.n_pairs >= PARALLEL_PAIRS else 1


def evaluate_into(layout: Layout, control: np.ndarray, out: np.ndarray, threads: int | None = None) -> bool:
    """Write the deformed (N, 3) positions for the control points (M, 3) into ``out`` (C-contiguous, of the
    layout's dtype) on ``threads`` threads (default: `thread_count`); False, with ``out`` untouched, where
    the kernel is unavailable or refuses."""
    kernel = _kernel() if available() else None
    if (
        kernel is None
        or out.dtype != layout.dtype
        or out.shape != (layout.n_vertices, 3)
        or not out.flags.c_contiguous
        or not out.flags.writeable
        or control.shape != layout.control_rest.shape
    ):
        return False
    control = np.ascontiguousarray(control, dtype=np.float64)
    function = kernel.pbk_evaluate_f32 if layout.dtype == np.float32 else kernel.pbk_evaluate_f64
    threads = max(1, min(thread_count(layout) if threads is None else threads, MAX_THREADS))
    status = function(
        layout.n_vertices, len(layout.triangles), control.ctypes.data, *layout.arguments, threads, out.ctypes.data
    )
    return status == 0


class Playback:
    """Successive evaluations of one layout into one output array that nothing else writes between them
    (the add-on's played face): only the vertices of groups with a moved triangle are summed, and a still
    group's vertices are written only when they last held something else (`Layout.group_mask`).

    ``rewritten`` are vertices that someone changes in ``out`` after every evaluation (the add-on's eyelids
    and lip guard): each evaluation writes their groups again. Any other change to ``out`` between evaluations
    is announced with `changed` (all vertices when none are given)."""

    def __init__(self, layout: Layout, out: np.ndarray, rewritten: np.ndarray | None = None):
        if out.dtype != layout.dtype or out.shape != (layout.n_vertices, 3) or not out.flags.c_contiguous:
            raise DeformError(f"out must be a C-contiguous {np.dtype(layout.dtype).name} array of shape (N, 3)")
        self.layout, self.out = layout, out
        self._fresh = np.zeros(len(layout.group_mask), dtype=np.uint8)  # 1: the group's vertices hold their rest
        self._work = np.empty(layout.n_vertices, dtype=np.int32)
        arrays = (layout.control_rest, layout.rest_bases, layout.triangles, layout.base, layout.plain_start)
        arrays += (layout.plain_key,)
        apex = (layout.apex_start, layout.apex_key, layout.apex_coef, layout.apex_scale, layout.apex_rest)
        groups = (layout.group_mask, layout.group_start, layout.group_vertex, self._fresh, self._work)
        self._arguments = (
            *(array.ctypes.data for array in arrays),
            layout.plain_coef.ctypes.data,
            *(None if a is None else a.ctypes.data for a in apex),
            layout.rest_out.ctypes.data,
            len(layout.group_mask),
            *(array.ctypes.data for array in groups),
        )
        self._at = out.ctypes.data
        self._rewritten = self.groups_of(np.zeros(0, np.intp) if rewritten is None else rewritten)
        # 1 where the last evaluation summed the group (a triangle of it not at rest): all others hold their rest
        self.off_rest = np.ones(len(self._fresh), dtype=np.uint8)

    @property
    def rewritten(self) -> np.ndarray:
        """The groups of the ``rewritten`` vertices."""
        return self._rewritten

    def groups_of(self, vertices: np.ndarray) -> np.ndarray:
        """The groups of these vertices, for `changed`."""
        return np.unique(self.layout.vertex_group[np.asarray(vertices, np.intp)])

    def changed(self, groups: np.ndarray | None = None) -> None:
        """The vertices of these groups (`groups_of`; all by default) of ``out`` were written by someone else since
        the last evaluation."""
        if groups is None:
            self._fresh.fill(0)
        else:
            self._fresh[groups] = 0

    def evaluate(self, control: np.ndarray, threads: int | None = None) -> bool:
        """Write the deformed positions for the control points (M, 3) into ``out``, as `evaluate_into` does; False,
        with ``out`` untouched, where the kernel is unavailable or refuses."""
        kernel = _kernel() if available() else None
        layout = self.layout
        if kernel is None or control.shape != layout.control_rest.shape or not self.out.flags.writeable:
            return False
        control = np.ascontiguousarray(control, dtype=np.float64)
        function = kernel.pbk_evaluate_groups_f32 if layout.dtype == np.float32 else kernel.pbk_evaluate_groups_f64
        threads = max(1, min(thread_count(layout) if threads is None else threads, MAX_THREADS))
        self._fresh[self._rewritten] = 0
        status = function(
            layout.n_vertices, len(layout.triangles), control.ctypes.data, *self._arguments, threads, self._at
        )
        if status != 0:
            self.changed()
            self.off_rest.fill(1)
            return False
        np.equal(self._fresh, 0, out=self.off_rest, casting="unsafe")  # fresh: the group holds its rest
        return True


@dataclass(frozen=True, eq=False)
class GuardArrays:
    """A lip guard's arrays as the kernel's `pbk_guard_lips_*` takes them (`lips.LipGuard` makes them once)."""

    vertices: np.ndarray  # (V,) int32
    side: np.ndarray  # (V,) float64
    slack: np.ndarray  # (V,) float64
    knots: np.ndarray  # (J,) int32
    order: np.ndarray  # int32
    starts: np.ndarray  # (2J + 1,) int32: where each run starts in order, then len(order)
    spread: np.ndarray  # (K, M) float64
    axes: np.ndarray  # (3, 3) float64
    reach: np.ndarray  # (2,) float64
    width: float
    skin: np.ndarray  # (S,) int32: the guarded vertices, then the skin beside them that follows their push
    sources: np.ndarray  # (k, S) int32: rows into vertices whose push each of skin shares
    shares: np.ndarray  # (k, S) float64: how much of each
    scratch: np.ndarray  # (2V,) float64
    n_vertices: int  # the least vertex count of a mesh these vertices index
    points: np.ndarray  # (M, 3) float64: each call's control points are copied here

    @functools.cached_property
    def arguments(self) -> tuple:
        """The kernel's arguments but the output (numpy's `.ctypes.data` costs about a microsecond a call)."""
        return (
            len(self.vertices),
            self.vertices.ctypes.data,
            self.side.ctypes.data,
            self.slack.ctypes.data,
            len(self.knots),
            self.knots.ctypes.data,
            self.order.ctypes.data,
            self.starts.ctypes.data,
            self.spread.ctypes.data,
            len(self.points),
            self.points.ctypes.data,
            self.axes.ctypes.data,
            self.reach.ctypes.data,
            self.width,
            len(self.skin),
            self.skin.ctypes.data,
            len(self.sources),
            self.sources.ctypes.data,
            self.shares.ctypes.data,
            self.scratch.ctypes.data,
        )

    @classmethod
    def of(
        cls, vertices, side, slack, knots, order, starts, spread, axes, reach, width, skin, sources, shares
    ) -> GuardArrays:
        def contiguous(array, dtype):
            return np.ascontiguousarray(array, dtype=dtype)

        vertices, order, starts, skin, sources = (
            np.asarray(a, dtype=np.int64) for a in (vertices, order, starts, skin, sources)
        )
        if not (
            np.shape(spread)[0] == GUARD_KNOTS
            and np.shape(axes) == (3, 3)
            and np.shape(reach) == (2,)
            and len(starts) == 2 * len(knots)
            and np.all((0 <= np.asarray(knots)) & (np.asarray(knots) < GUARD_KNOTS))
            and np.all((0 <= order) & (order < len(vertices)))
            and np.all(np.diff(np.r_[starts, len(order)]) > 0)
            and (len(starts) == 0 or starts[0] == 0)
            and np.all(vertices >= 0)
            and len(vertices) == len(side) == len(slack)
            and width > 0.0
            and skin.ndim == 1
            and np.array_equal(skin[: len(vertices)], vertices)
            and np.all(skin >= 0)
            and sources.ndim == 2
            and np.shape(shares) == (len(sources), len(skin))
            and sources.shape[1] == len(skin)
            and np.all((0 <= sources) & (sources < len(vertices)))
        ):
            raise DeformError("inconsistent lip guard arrays")
        return cls(
            vertices=contiguous(vertices, np.int32),
            side=contiguous(side, np.float64),
            slack=contiguous(slack, np.float64),
            knots=contiguous(knots, np.int32),
            order=contiguous(order, np.int32),
            starts=contiguous(np.r_[starts, len(order)], np.int32),
            spread=contiguous(spread, np.float64),
            axes=contiguous(axes, np.float64),
            reach=contiguous(reach, np.float64),
            width=float(width),
            skin=contiguous(skin, np.int32),
            sources=contiguous(sources, np.int32),
            shares=contiguous(shares, np.float64),
            scratch=np.empty(2 * len(vertices)),
            n_vertices=int(skin.max(initial=-1)) + 1,
            points=np.empty((np.shape(spread)[1], 3)),
        )


def _writable_positions(out: np.ndarray, n_vertices: int) -> bool:
    """Whether the kernel can write `out` in place: (N, 3) float32 or float64, C-contiguous, writeable, N at least
    `n_vertices`."""
    return (
        out.dtype in (np.float32, np.float64)
        and out.ndim == 2
        and out.shape[1] == 3
        and out.flags.c_contiguous
        and out.flags.writeable
        and n_vertices <= len(out)
    )


def guard_lips_into(arrays: GuardArrays, out: np.ndarray, points: np.ndarray) -> bool | None:
    """`lips.guard_lips` by the kernel, in place on ``out`` (N, 3, C-contiguous float32 or float64) for the control
    points (M, 3): True when it moved any vertex, False when none; None, with ``out`` untouched, where the kernel is
    unavailable. Not thread-safe (``scratch``)."""
    kernel = _kernel() if available() else None
    if kernel is None or not _writable_positions(out, arrays.n_vertices) or points.shape != arrays.points.shape:
        return None
    arguments = arrays.arguments
    arrays.points[...] = points
    status = kernel.pbk_guard_lips(int(out.dtype == np.float32), *arguments, out.ctypes.data)
    return None if status == 1 else status == 2


@dataclass(frozen=True, eq=False)
class ContactArrays:
    """A lip guard's contact (`lips.Contact`) and carry as the kernel's `pbk_press_apart` takes them (`of` checks
    every index the kernel follows; `lips.press_apart` makes them once per guard)."""

    vertices: np.ndarray  # (P,) int32: the contact's mesh vertices
    rows: np.ndarray  # (P,) int32: their rows among the guarded vertices
    ends: np.ndarray  # (S, 2) int32: the samples, rows into vertices
    look: np.ndarray  # (S,) float64
    keep: np.ndarray  # (S,) float64
    direction: np.ndarray  # (S, 3) float64
    triangles: np.ndarray  # (T, 3) int32: the other lips' skin, those facing 1 first
    n_first: int  # how many of triangles face 1
    reach: float
    axes: np.ndarray  # (3, 3) float64
    n_guarded: int
    skin: np.ndarray  # (K,) int32
    sources: np.ndarray  # (k, K) int32
    shares: np.ndarray  # (k, K) float64
    order: np.ndarray  # (T,) int32: the kernel keeps it sorted by the triangles' boxes from call to call
    scratch: np.ndarray  # float64, as many as the kernel asks for (empty where there was no kernel)
    n_vertices: int  # the least vertex count of a mesh these vertices index

    @functools.cached_property
    def arguments(self) -> tuple:
        """The kernel's arguments but the output type and the output (each array by its address)."""
        arrays = (self.vertices, self.rows, self.ends, self.look, self.keep, self.direction, self.triangles)
        sizes = (len(self.vertices), len(self.ends), len(self.triangles), self.n_first)
        carry = (self.n_guarded, len(self.skin), self.skin, len(self.sources), self.sources, self.shares)
        ordered = (sizes[0], *arrays[:2], sizes[1], *arrays[2:6], *sizes[2:], arrays[6], self.reach, self.axes, *carry)
        return tuple(a.ctypes.data if isinstance(a, np.ndarray) else a for a in (*ordered, self.order, self.scratch))

    def __getstate__(self) -> dict:
        """Pickled and copied without `arguments`: its addresses are this process's, of these very arrays."""
        return {name: value for name, value in self.__dict__.items() if name != "arguments"}

    @classmethod
    def of(
        cls, vertices, rows, ends, look, keep, direction, triangles, facing, reach, axes, n_guarded, skin, sources,
        shares, positions=None,
    ) -> ContactArrays:  # fmt: skip
        """The arrays, checked (a `DeformError` where an index is out of range); with the mesh's (N, 3) `positions`,
        the triangles' first order is theirs (else the kernel's first call sorts them from the mesh's order)."""
        vertices, rows, ends, triangles, skin, sources = (
            np.asarray(a, dtype=np.int64) for a in (vertices, rows, ends, triangles, skin, sources)
        )
        look, facing = np.asarray(look, dtype=np.float64), np.asarray(facing, dtype=np.float64)
        n_first = int(np.sum(facing == 1.0))
        if not (
            vertices.ndim == 1
            and np.all(vertices >= 0)
            and rows.shape == vertices.shape
            and np.all((0 <= rows) & (rows < n_guarded))
            and len(np.unique(rows)) == len(rows)
            and ends.ndim == 2
            and ends.shape[1] == 2
            and np.all((0 <= ends) & (ends < len(vertices)))
            and look.shape == np.shape(keep) == (len(ends),)
            and np.all(np.abs(look) == 1.0)
            and np.shape(direction) == (len(ends), 3)
            and triangles.ndim == 2
            and triangles.shape[1] == 3
            and np.all(triangles >= 0)
            and facing.shape == (len(triangles),)
            and np.all(facing[:n_first] == 1.0)
            and np.all(facing[n_first:] == -1.0)
            and np.shape(axes) == (3, 3)
            and skin.ndim == 1
            and 0 <= n_guarded <= len(skin)
            and np.all(skin >= 0)
            and sources.ndim == 2
            and sources.shape[1] == len(skin)
            and np.shape(shares) == sources.shape
            and np.all((0 <= sources) & (sources < n_guarded))
            and max(len(vertices), len(ends), len(triangles), len(skin)) < 2**31
        ):
            raise DeformError("inconsistent lip contact arrays")
        n_vertices = 1 + max(int(a.max(initial=-1)) for a in (vertices, triangles, skin))
        kernel = _kernel()
        size = (len(vertices), len(ends), len(triangles), int(n_guarded))
        order = np.arange(len(triangles))
        if positions is not None and len(positions) >= n_vertices:
            least = (np.asarray(positions, dtype=np.float64)[triangles] @ np.asarray(axes)[0]).min(axis=1)
            order = np.concatenate([np.argsort(least[:n_first]), n_first + np.argsort(least[n_first:])])
        return cls(
            vertices=np.ascontiguousarray(vertices, np.int32),
            rows=np.ascontiguousarray(rows, np.int32),
            ends=np.ascontiguousarray(ends, np.int32),
            look=np.ascontiguousarray(look),
            keep=np.ascontiguousarray(keep, np.float64),
            direction=np.ascontiguousarray(direction, np.float64),
            triangles=np.ascontiguousarray(triangles, np.int32),
            n_first=n_first,
            reach=float(reach),
            axes=np.ascontiguousarray(axes, np.float64),
            n_guarded=int(n_guarded),
            skin=np.ascontiguousarray(skin, np.int32),
            sources=np.ascontiguousarray(sources, np.int32),
            shares=np.ascontiguousarray(shares, np.float64),
            order=np.ascontiguousarray(order, np.int32),
            scratch=np.empty(0 if kernel is None else int(kernel.pbk_press_apart_scratch(*size))),
            n_vertices=n_vertices,
        )


def press_apart_into(arrays: ContactArrays, out: np.ndarray) -> bool | None:
    """`lips.press_apart` by the kernel, in place on ``out`` (N, 3, C-contiguous float32 or float64): True when it
    moved any vertex, False when none; None, with ``out`` untouched, where the kernel is unavailable or ``out`` is not
    one it can write. Not thread-safe (the scratch and the triangles' order)."""
    kernel = _kernel() if available() else None
    if kernel is None or not _writable_positions(out, arrays.n_vertices) or not arrays.scratch.size:
        return None
    status = kernel.pbk_press_apart(int(out.dtype == np.float32), *arrays.arguments, out.ctypes.data)
    return None if status == 1 else status == 2


def nearest_sources(
    starts: np.ndarray, ends: np.ndarray, length: np.ndarray, sources: np.ndarray, k: int, radius: float, tie: float
) -> dict[int, list] | None:
    """`lips._nearest_sources` by the kernel (the same lists, in the same order), for the graph of edges
    ``starts`` (n + 1,), ``ends``, ``length`` and the vertices ``sources``; None where the kernel is unavailable
    or a vertex has more ties with its k-th nearest than it has room for."""
    kernel = _kernel() if available() else None
    starts, ends = np.ascontiguousarray(starts, np.int32), np.ascontiguousarray(ends, np.int32)
    length, sources = np.ascontiguousarray(length, np.float64), np.ascontiguousarray(sources, np.int32)
    n = len(starts) - 1
    if not (
        kernel is not None
        and n >= 0
        and len(ends) == len(length)
        and (n == 0 or (starts[0] == 0 and starts[-1] == len(ends) and np.all(np.diff(starts) >= 0)))
        and np.all((0 <= ends) & (ends < n))
        and np.all((0 <= sources) & (sources < n))
    ):
        return None
    cap = k + NEAREST_TIES
    count, dist, row = np.zeros(n, np.int32), np.empty((n, cap)), np.empty((n, cap), np.int32)
    pointers = (a.ctypes.data for a in (starts, ends, length))
    status = kernel.pbk_nearest_sources(
        n, *pointers, len(sources), sources.ctypes.data, k, radius, tie, cap, count.ctypes.data, dist.ctypes.data,
        row.ctypes.data,
    )  # fmt: skip
    if status != 0:
        return None
    reached = np.flatnonzero(count)
    counts, dists, rows = count[reached].tolist(), dist[reached].tolist(), row[reached].tolist()
    return {
        v: list(zip(d[:c], r[:c], strict=True))
        for v, c, d, r in zip(reached.tolist(), counts, dists, rows, strict=True)
    }


def bind_frames(frames: TriangleFrames, centres: np.ndarray) -> np.ndarray:
    """(T, BIND_FRAME) float64: each triangle's frame and bounding-sphere centre as the kernel's binding
    functions read them (laid out in native/bind_regions.h)."""
    t = len(frames.corners)
    edge_normals = frames.edge_normals
    gram = np.einsum("tjk,tjk->tj", edge_normals, np.roll(edge_normals, 1, axis=1))  # g_j = b_j · b_(j−1)
    parts = (frames.corners, frames.inverse_frames, frames.unit_edges, edge_normals, frames.edge_lengths)
    parts += (frames.normals, gram, centres)
    return np.ascontiguousarray(np.concatenate([np.reshape(a, (t, -1)) for a in parts], axis=1), dtype=np.float64)


def _frame_row(frame: np.ndarray) -> np.ndarray:
    if frame.shape != (BIND_FRAME,) or frame.dtype != np.float64 or not frame.flags.c_contiguous:
        raise ValueError("a triangle's frame must be a row of bind_frames")
    return frame


def locate(frame: np.ndarray, points: np.ndarray) -> Location | None:
    """`regions.locate` by the kernel for the triangle whose `bind_frames` row is ``frame``; None where the
    kernel is unavailable."""
    kernel = _kernel() if available() else None
    if kernel is None:
        return None
    frame = _frame_row(frame)
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    region, distance, apex_distance = np.empty(n, np.int8), np.empty(n), np.empty(n)
    face_local, region_local = np.empty((n, 3)), np.empty((n, 3))
    pointers = (a.ctypes.data for a in (points, frame, region, distance, face_local, region_local, apex_distance))
    kernel.pbk_locate(n, *pointers)
    return Location(region, distance, face_local, region_local, apex_distance)


def distance_bound(frame: np.ndarray, points: np.ndarray) -> np.ndarray | None:
    """`regions.distance_lower_bound` by the kernel (see `locate`); None where the kernel is unavailable."""
    kernel = _kernel() if available() else None
    if kernel is None:
        return None
    frame = _frame_row(frame)
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    bound = np.empty(len(points))
    kernel.pbk_distance_bound(len(points), points.ctypes.data, frame.ctypes.data, bound.ctypes.data)
    return bound


class Collector:
    """`planar_bones.bind`'s per-triangle pairs by the kernel (`pbk_collect`), over one set of rest vertices;
    `collect` returns None where the kernel is unavailable."""

    FIELDS = ("vertex", "weight", "region", "face_local", "region_local", "apex_distance")

    def __init__(self, rest: np.ndarray, squared_norms: np.ndarray):
        self.rest = np.ascontiguousarray(rest, dtype=np.float64)
        n = len(self.rest)
        self.squared_norms = np.ascontiguousarray(squared_norms, dtype=np.float64)
        if self.rest.shape != (n, 3) or self.squared_norms.shape != (n,) or n >= 2**31:
            raise ValueError("rest must be (N, 3) and squared_norms (N,)")
        self._out = {
            "vertex": np.empty(n, np.int32),
            "weight": np.empty(n),
            "region": np.empty(n, np.int8),
            "face_local": np.empty((n, 3)),
            "region_local": np.empty((n, 3)),
            "apex_distance": np.empty(n),
        }

    def collect(
        self,
        frame: np.ndarray,
        mask: np.ndarray | None,
        reach_squared: float,
        bound_limit: float,
        radius: float,
        exponent: float,
    ) -> dict[str, np.ndarray] | None:
        """The kept pairs (vertex order) of the triangle whose `bind_frames` row is ``frame``: candidates within
        ``reach_squared`` of its bounding-sphere centre, with a ``mask`` weight above 0, a distance bound below
        ``bound_limit``; kept where the eq. 9 weight (``radius``, ``exponent``) times the mask is above 0."""
        kernel = _kernel() if available() else None
        if kernel is None:
            return None
        frame = _frame_row(frame)
        n = len(self.rest)
        if mask is not None:
            mask = np.ascontiguousarray(mask, dtype=np.float64)
            if mask.shape != (n,):
                raise ValueError("mask must be (N,)")
        out = self._out
        count = kernel.pbk_collect(
            n, self.rest.ctypes.data, self.squared_norms.ctypes.data, None if mask is None else mask.ctypes.data,
            frame.ctypes.data, reach_squared, bound_limit, radius, exponent,
            *(out[name].ctypes.data for name in self.FIELDS),
        )  # fmt: skip
        result = {name: out[name][:count].copy() for name in self.FIELDS}
        result["vertex"] = result["vertex"].astype(np.intp)
        return result


def fold_free_sweeps(classes, faces, g, gf, norm, lower, upper, w, sweeps, omega, tolerance) -> int | None:
    """`eyelids.fold_free_sweeps` by the kernel, in place on ``w`` (N, 2, C-contiguous float64); the sweeps made,
    or None (``w`` untouched) where the kernel is unavailable."""
    kernel = _kernel() if available() else None
    n_faces = len(faces)
    if kernel is None or w.dtype != np.float64 or w.ndim != 2 or w.shape[1] != 2 or not w.flags.c_contiguous:
        return None
    members = np.ascontiguousarray(np.concatenate(classes) if classes else np.zeros(0), dtype=np.int64)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    shapes = ((g, (n_faces, 3)), (gf, (n_faces, 3, 2)), (norm, (n_faces, 2)), (lower, (n_faces, 2)))
    shapes += ((upper, (n_faces, 2)),)
    if not (
        faces.shape == (n_faces, 3)
        and all(np.shape(a) == shape for a, shape in shapes)
        and np.array_equal(np.sort(members), np.arange(n_faces))
        and (n_faces == 0 or (faces.min() >= 0 and faces.max() < len(w)))
    ):
        return None
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a, _shape in shapes]
    class_start = np.ascontiguousarray(np.cumsum([0] + [len(c) for c in classes]), dtype=np.int64)
    pointers = (a.ctypes.data for a in (class_start, members, faces, *arrays, w))
    return int(kernel.pbk_fold_free_sweeps(len(classes), *pointers, sweeps, omega, tolerance))


def unfold(mesh, positions: np.ndarray, start: np.ndarray | None, max_steps: int, step: float, check_every: int,
           stall_checks: int, bisections: int, margin: float, momentum: bool):  # fmt: skip
    """`unfold.unfold` by the kernel, in place on ``positions`` ((N, 3) C-contiguous float32 of the `unfold.SkinMesh`
    ``mesh``), first looking at the triangles at the ``start`` vertices (at all where None), with Nesterov's momentum
    where ``momentum``: (moved vertices, steps,
    triangles left, share kept), or None (``positions`` untouched) where the kernel is unavailable or the positions
    are not float32. The kernel's work space is the mesh's (`unfold.SkinMesh.work`), kept between calls."""
    kernel = _kernel() if available() else None
    if (
        kernel is None
        or positions.dtype != np.float32
        or positions.shape != mesh.rest.shape
        or not positions.flags.c_contiguous
        or not positions.flags.writeable
    ):
        return None
    work = mesh.work
    if len(work) != kernel.pbk_unfold_work_bytes(len(positions), len(mesh.triangles)):
        return None
    start = None if start is None else np.ascontiguousarray(start, dtype=np.int32)
    moved = np.empty(len(positions), np.int32)
    result = np.zeros(3, np.int64)
    share = np.ones(1)
    arrays = (mesh.rest, mesh.triangles, mesh.rest_normals, mesh.neighbour_start, mesh.neighbours, mesh.weights)
    arrays += (mesh.corner_start, mesh.corner_triangles, positions)
    kernel.pbk_unfold(
        len(positions), len(mesh.triangles), *(a.ctypes.data for a in arrays),
        -1 if start is None else len(start), None if start is None else start.ctypes.data, work.ctypes.data,
        max_steps, step, check_every, stall_checks, bisections, margin, int(momentum), moved.ctypes.data,
        result.ctypes.data, share.ctypes.data,
    )  # fmt: skip
    return moved[: result[0]].copy(), int(result[1]), int(result[2]), float(share[0])


def unfold_work_bytes(n_vertices: int, n_triangles: int) -> int:
    """The size of `unfold`'s work space on a mesh (0 where the kernel is unavailable)."""
    kernel = _kernel() if available() else None
    return 0 if kernel is None else int(kernel.pbk_unfold_work_bytes(n_vertices, n_triangles))


def turned_at(look, positions: np.ndarray) -> np.ndarray | None:
    """`unfold.Look.turned_corners` by the kernel, or None where it is unavailable or the positions are not
    float32."""
    kernel = _kernel() if available() else None
    if kernel is None or positions.dtype != np.float32 or positions.shape != look.mesh.rest.shape:
        return None
    if not positions.flags.c_contiguous:
        return None
    found = look.found
    count = kernel.pbk_turned_at(len(look.class_start) - 1, *look.arguments, positions.ctypes.data, found.ctypes.data)
    return found[: 3 * count].copy()
