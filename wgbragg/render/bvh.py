"""Bounding volume hierarchy over a triangle mesh, built in numpy for GPU traversal.

Layout
------
Nodes are stored depth-first with siblings side by side: an inner node ``i`` has its children
at ``node_left[i]`` and ``node_left[i] + 1``, and the subtree of the left child follows the
pair before the subtree of the right child. The root is node 0. A leaf has
``node_count[i] > 0`` and ``node_left[i] == -1``; its triangles are
``triangle_order[node_first[i] : node_first[i] + node_count[i]]``. An inner node has
``node_count[i] == 0`` and ``node_first[i] == 0``. The renderer traverses it as nodes of
four children (:func:`collapse_wide`), whose leaves and face order are this tree's.

Bounds are float32 (what the GPU stores) and are rounded outward, so every box contains its
triangles exactly even though the vertices are float64. Distances are in scene units.

References
----------
.. [1] I. Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies",
   IEEE Symposium on Interactive Ray Tracing, 2007 (binned SAH on the axis of largest
   centroid extent).
.. [2] T. Moller and B. Trumbore, "Fast, minimum storage ray-triangle intersection",
   Journal of Graphics Tools 2(1), 1997.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

__all__ = ["BVH", "build_bvh", "collapse_wide"]

# Meshes at least this large show a progress bar unless the caller decides.
_PROGRESS_THRESHOLD = 500_000


def _readonly(array: np.ndarray) -> np.ndarray:
    # A copy, so that freezing it never freezes the caller's array.
    array = np.array(array, order="C")
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class BVH:
    """A flattened bounding volume hierarchy; see the module docstring for the layout.

    Attributes
    ----------
    node_min, node_max : ndarray, shape (N, 3), float32
        Box corners in scene units, rounded outward from the float64 geometry.
    node_left : ndarray, shape (N,), int32
        Index of the left child (the right child is ``node_left + 1``); -1 for leaves.
    node_first, node_count : ndarray, shape (N,), int32
        Leaf triangle range in ``triangle_order``; ``node_count`` is 0 for inner nodes.
    triangle_order : ndarray, shape (F,), int32
        Face indices, grouped by leaf.
    vertices : ndarray, shape (V, 3), float64
        The mesh vertices the tree was built over (used by :meth:`intersect`).
    faces : ndarray, shape (F, 3), int32
        The mesh faces the tree was built over.
    depth : int
        Edges on the longest root-to-leaf path; a traversal stack needs ``depth + 1`` slots.
    """

    node_min: np.ndarray
    node_max: np.ndarray
    node_left: np.ndarray
    node_first: np.ndarray
    node_count: np.ndarray
    triangle_order: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    depth: int

    @property
    def node_total(self) -> int:
        """Number of nodes N."""
        return len(self.node_left)

    @property
    def nbytes(self) -> int:
        """Bytes the node arrays and ``triangle_order`` take on the GPU.

        The vertex and index buffers belong to the mesh and are not counted.
        """
        arrays = (
            self.node_min,
            self.node_max,
            self.node_left,
            self.node_first,
            self.node_count,
            self.triangle_order,
        )
        return sum(array.nbytes for array in arrays)

    def intersect(self, origins, directions, t_max=math.inf):
        """Closest hit of each ray: a float64 numpy reference for the GPU traversal.

        Rays are traversed in lockstep, each with its own stack; triangles are two-sided and
        tested with the Moller-Trumbore algorithm [2]_. A hit needs ``0 < t < t_max``.

        Parameters
        ----------
        origins : array_like, shape (R, 3) or (3,)
            Ray origins in scene units.
        directions : array_like, shape (R, 3) or (3,)
            Ray directions, non-zero; need not be unit length (``t`` is then in units of
            the direction's length).
        t_max : float or array_like, shape (R,)
            Exclusive upper bound on ``t``, > 0.

        Returns
        -------
        t : ndarray, shape (R,), float64
            Ray parameter of the closest hit, ``inf`` for a miss.
        face : ndarray, shape (R,), int64
            Index of the hit face, -1 for a miss.
        u, v : ndarray, shape (R,), float64
            Barycentric coordinates of the hit (weights of the face's second and third
            vertex); NaN for a miss.
        """
        origins, directions, t_max = _check_rays(origins, directions, t_max)
        rays = len(origins)
        best_t = np.broadcast_to(t_max, (rays,)).copy()
        best_face = np.full(rays, -1, dtype=np.int64)
        best_u = np.full(rays, np.nan)
        best_v = np.full(rays, np.nan)
        with np.errstate(divide="ignore"):
            inverse = 1.0 / directions

        box_min = self.node_min.astype(np.float64)
        box_max = self.node_max.astype(np.float64)
        centre = 0.5 * (box_min + box_max)
        stack = np.zeros((rays, self.depth + 2), dtype=np.int64)
        top = np.ones(rays, dtype=np.int64)
        active = np.arange(rays)
        while True:
            active = active[top[active] > 0]
            if active.size == 0:
                break
            top[active] -= 1
            node = stack[active, top[active]]
            near, far = _slabs(origins[active], inverse[active], box_min[node], box_max[node])
            hit = (near <= far) & (far >= 0.0) & (near < best_t[active])
            ray, node = active[hit], node[hit]

            leaf = self.node_count[node] > 0
            self._test_leaves(
                ray[leaf], node[leaf], origins, directions, best_t, best_face, best_u, best_v
            )

            ray, node = ray[~leaf], node[~leaf]
            left = self.node_left[node].astype(np.int64)
            # Visit the child whose centre lies further along the ray last, so the nearer one
            # shrinks best_t first and prunes more of the other.
            toward_right = np.einsum("ij,ij->i", directions[ray], centre[left + 1] - centre[left])
            first_pushed = np.where(toward_right > 0.0, left + 1, left)
            stack[ray, top[ray]] = first_pushed
            stack[ray, top[ray] + 1] = np.where(toward_right > 0.0, left, left + 1)
            top[ray] += 2

        best_t[best_face < 0] = np.inf
        return best_t, best_face, best_u, best_v

    def _test_leaves(self, ray, node, origins, directions, best_t, best_face, best_u, best_v):
        first = self.node_first[node].astype(np.int64)
        count = self.node_count[node].astype(np.int64)
        for slot in range(int(count.max(initial=0))):
            inside = slot < count
            r = ray[inside]
            face = self.triangle_order[first[inside] + slot].astype(np.int64)
            corners = self.vertices[self.faces[face]]
            t, u, v = _moller_trumbore(
                origins[r], directions[r], corners[:, 0], corners[:, 1], corners[:, 2]
            )
            closer = t < best_t[r]
            r = r[closer]
            best_t[r] = t[closer]
            best_face[r] = face[closer]
            best_u[r] = u[closer]
            best_v[r] = v[closer]


def _check_rays(origins, directions, t_max) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`BVH.intersect`'s rays as float64 arrays of shape (R, 3), and ``t_max``, checked."""
    origins, directions = np.broadcast_arrays(
        _as_points("origins", origins), _as_points("directions", directions)
    )
    if np.any(np.all(directions == 0.0, axis=1)):
        raise ValueError("directions must be non-zero vectors")
    rays = len(origins)
    t_max = np.asarray(t_max, dtype=np.float64)
    if t_max.ndim > 1 or (t_max.ndim == 1 and len(t_max) != rays):
        raise ValueError(f"t_max must be a scalar or have shape ({rays},)")
    if np.isnan(t_max).any() or np.any(t_max <= 0.0):
        raise ValueError("t_max must be > 0")
    return origins, directions, t_max


def _moller_trumbore(origins, directions, v0, v1, v2):
    """Ray-triangle distances by the Moller-Trumbore algorithm [2]_, two-sided, float64.

    Parameters
    ----------
    origins, directions : ndarray, shape (..., 3)
        Rays in scene units.
    v0, v1, v2 : ndarray, shape (..., 3)
        Triangle corners, broadcast against the rays.

    Returns
    -------
    t : ndarray
        Ray parameter of the hit, ``inf`` where the ray misses, is parallel to the triangle,
        or hits at ``t <= 0``.
    u, v : ndarray
        Barycentric weights of ``v1`` and ``v2`` at the hit (meaningless for misses).
    """
    edge1 = v1 - v0
    edge2 = v2 - v0
    p = np.cross(directions, edge2)
    det = np.sum(edge1 * p, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse_det = 1.0 / det
        s = origins - v0
        u = np.sum(s * p, axis=-1) * inverse_det
        q = np.cross(s, edge1)
        v = np.sum(directions * q, axis=-1) * inverse_det
        t = np.sum(edge2 * q, axis=-1) * inverse_det
    hit = (det != 0.0) & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
    return np.where(hit, t, np.inf), u, v


def _slabs(origins, inverse, box_min, box_max):
    with np.errstate(invalid="ignore"):
        t0 = (box_min - origins) * inverse
        t1 = (box_max - origins) * inverse
    # fmin/fmax skip the NaN of 0 * inf (a ray parallel to, and in the plane of, a slab
    # face), which keeps that axis from rejecting the box.
    near = np.fmax.reduce(np.fmin(t0, t1), axis=1)
    far = np.fmin.reduce(np.fmax(t0, t1), axis=1)
    # Rounding in the slab arithmetic must never reject a box that a triangle touches from
    # inside, so the far distance is widened by a few float64 ulps.
    with np.errstate(invalid="ignore"):
        widened = far + (1e-12 * np.abs(far) + 1e-300)
    return near, np.where(np.isfinite(far), widened, far)


def _as_points(name: str, value) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be an array of real numbers, shape (R, 3)") from error
    array = np.atleast_2d(array)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (R, 3), got {np.shape(value)}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite")
    return array


def _outward_float32(low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    low32 = low.astype(np.float32)
    high32 = high.astype(np.float32)
    low32 = np.where(low32 > low, np.nextafter(low32, np.float32(-np.inf)), low32)
    high32 = np.where(high32 < high, np.nextafter(high32, np.float32(np.inf)), high32)
    return low32, high32


def _check_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    vertices = _as_points("vertices", vertices)
    raw = np.asarray(faces)
    if raw.ndim != 2 or raw.shape[1] != 3 or raw.shape[0] == 0:
        raise ValueError(f"faces must have shape (F, 3) with F >= 1, got {raw.shape}")
    if raw.dtype.kind not in "iu":
        raise ValueError(f"faces must hold integers, got dtype {raw.dtype}")
    if raw.min() < 0 or raw.max() >= len(vertices):
        raise ValueError(f"faces must index vertices 0..{len(vertices) - 1}")
    if len(raw) >= 2**31:
        raise ValueError("faces must number fewer than 2**31 (int32 indices)")
    return vertices, raw.astype(np.int32)


def build_bvh(vertices, faces, leaf_size: int = 4, bins: int = 16, progress: bool | None = None):
    """Build a binned-SAH BVH over a triangle mesh.

    All nodes of one tree level are split at once with array operations, so the Python
    work grows with the depth of the tree, not with its size. Each node is split on the
    axis of largest centroid extent at the best of ``bins - 1`` bin boundaries under the
    surface area heuristic [1]_; a node whose centroids coincide is split in half by
    position. Nodes are split until they hold at most ``leaf_size`` triangles.

    Parameters
    ----------
    vertices : array_like, shape (V, 3)
        Vertex positions in scene units, finite.
    faces : array_like, shape (F, 3), integer
        Vertex indices of each triangle, F >= 1.
    leaf_size : int
        Most triangles in a leaf, 1 to 64.
    bins : int
        SAH bins per split, 2 to 256.
    progress : bool or None
        Show a tqdm bar counting triangles settled into leaves; ``None`` shows it for
        meshes of 500,000 triangles or more.

    Returns
    -------
    BVH
        The flattened hierarchy (see the module docstring for its layout).
    """
    vertices, faces = _check_mesh(vertices, faces)
    if isinstance(leaf_size, bool) or not isinstance(leaf_size, int) or not 1 <= leaf_size <= 64:
        raise ValueError(f"leaf_size must be an integer from 1 to 64, got {leaf_size!r}")
    if isinstance(bins, bool) or not isinstance(bins, int) or not 2 <= bins <= 256:
        raise ValueError(f"bins must be an integer from 2 to 256, got {bins!r}")
    triangles = len(faces)
    if progress is None:
        progress = triangles >= _PROGRESS_THRESHOLD

    bounds = _Bounds.of(vertices, faces)
    nodes = _Nodes.root(bounds, triangles)
    levels = [np.array([0])]
    active = levels[0] if triangles > leaf_size else levels[0][:0]

    bar = tqdm(total=triangles, desc="BVH", unit="tri", disable=not progress)
    bar.update(triangles - int(nodes.count[active].sum()))
    while active.size:
        level = _Level.of(nodes, active)
        children = nodes.split(active, level, _best_splits(level, bounds, bins))
        levels.append(children)
        active = children[nodes.count[children] > leaf_size]
        bar.update(len(level.tris) - int(nodes.count[active].sum()))
    bar.close()
    return _flatten(nodes, levels, vertices, faces)


@dataclass(frozen=True)
class _Bounds:
    """Per-triangle bounding boxes and centroids, one array per axis: component arrays keep
    the per-level gathers and ufunc.at reductions one-dimensional, which numpy runs far faster
    than their (n, 3) forms."""

    low: list[np.ndarray]
    high: list[np.ndarray]
    centroid: list[np.ndarray]

    @classmethod
    def of(cls, vertices: np.ndarray, faces: np.ndarray) -> _Bounds:
        corners = vertices[faces]
        low = corners.min(axis=1)
        high = corners.max(axis=1)
        del corners
        centroid = 0.5 * (low + high)
        return cls(*([np.ascontiguousarray(a[:, k]) for k in range(3)]
                     for a in (low, high, centroid)))

    def total(self) -> tuple[np.ndarray, np.ndarray]:
        """The box around every triangle."""
        return (np.array([a.min() for a in self.low]), np.array([a.max() for a in self.high]))


@dataclass(frozen=True)
class _Level:
    """The triangles of a level's active nodes, gathered node after node."""

    count: np.ndarray  # per node: its triangles
    start: np.ndarray  # per node: its first slot in the triangle order
    offset: np.ndarray  # per node: its first triangle in ``tris``
    segment: np.ndarray  # per triangle: its node (0 .. active - 1)
    local: np.ndarray  # per triangle: its rank within its node
    tris: np.ndarray  # per triangle: its face index

    @classmethod
    def of(cls, nodes: _Nodes, active: np.ndarray) -> _Level:
        count = nodes.count[active]
        start = nodes.first[active]
        offset = np.concatenate(([0], np.cumsum(count)[:-1]))
        total = int(count.sum())
        segment = np.repeat(np.arange(len(active)), count)
        local = np.arange(total) - offset[segment]
        tris = nodes.order[start[segment] + local]
        return cls(count, start, offset, segment, local, tris)


@dataclass(frozen=True)
class _Split:
    """Each active node's split: which of its triangles go left, how many, and the children's
    boxes (``splittable`` False: split in half by position, both children in the parent's)."""

    goes_left: np.ndarray  # per triangle
    n_left: np.ndarray
    splittable: np.ndarray
    left_low: np.ndarray
    left_high: np.ndarray
    right_low: np.ndarray
    right_high: np.ndarray


def _binned(level: _Level, bounds: _Bounds, bins: int):
    """Each triangle's SAH bin along its node's axis of largest centroid extent, whether the
    node can be split there (its centroids do not coincide), and per node and bin the triangle
    count and box, shapes (nodes, bins) and (nodes, bins, 3)."""
    nodes = len(level.count)
    tris, offset, segment = level.tris, level.offset, level.segment
    cmin = np.stack([np.minimum.reduceat(bounds.centroid[k][tris], offset) for k in range(3)], 1)
    cmax = np.stack([np.maximum.reduceat(bounds.centroid[k][tris], offset) for k in range(3)], 1)
    extent = cmax - cmin
    axis = np.argmax(extent, axis=1)
    rows = np.arange(nodes)
    span = extent[rows, axis]
    splittable = span > 0.0
    with np.errstate(divide="ignore"):
        scale = np.where(splittable, bins / span, 0.0)
    axis_t = axis[segment]
    value = np.choose(axis_t, [bounds.centroid[k][tris] for k in range(3)])
    bin_index = ((value - cmin[rows, axis][segment]) * scale[segment]).astype(np.int64)
    np.clip(bin_index, 0, bins - 1, out=bin_index)
    key = segment * bins + bin_index

    cells = nodes * bins
    bin_count = np.bincount(key, minlength=cells).reshape(-1, bins)
    bin_low = np.full((3, cells), np.inf)
    bin_high = np.full((3, cells), -np.inf)
    for k in range(3):
        np.minimum.at(bin_low[k], key, bounds.low[k][tris])
        np.maximum.at(bin_high[k], key, bounds.high[k][tris])
    bin_low = bin_low.reshape(3, -1, bins).transpose(1, 2, 0)
    bin_high = bin_high.reshape(3, -1, bins).transpose(1, 2, 0)
    return bin_index, splittable, bin_count, bin_low, bin_high


def _best_splits(level: _Level, bounds: _Bounds, bins: int) -> _Split:
    """The split of each active node at the bin boundary of least surface area cost [1]_."""
    bin_index, splittable, bin_count, bin_low, bin_high = _binned(level, bounds, bins)
    count, segment = level.count, level.segment
    left_low = np.minimum.accumulate(bin_low, axis=1)[:, :-1]
    left_high = np.maximum.accumulate(bin_high, axis=1)[:, :-1]
    right_low = np.minimum.accumulate(bin_low[:, ::-1], axis=1)[:, ::-1][:, 1:]
    right_high = np.maximum.accumulate(bin_high[:, ::-1], axis=1)[:, ::-1][:, 1:]
    left_n = np.cumsum(bin_count, axis=1)[:, :-1]
    right_n = count[:, None] - left_n
    with np.errstate(invalid="ignore"):
        cost = _half_area(left_low, left_high) * left_n
        cost += _half_area(right_low, right_high) * right_n
    # A boundary with an empty side is no split; unsplittable nodes have only those.
    cost[(left_n == 0) | (right_n == 0)] = np.inf
    best = np.argmin(cost, axis=1)
    rows = np.arange(len(count))
    return _Split(
        goes_left=np.where(splittable[segment], bin_index <= best[segment],
                           level.local < (count // 2)[segment]),
        n_left=np.where(splittable, left_n[rows, best], count // 2),
        splittable=splittable,
        left_low=left_low[rows, best],
        left_high=left_high[rows, best],
        right_low=right_low[rows, best],
        right_high=right_high[rows, best],
    )


@dataclass
class _Nodes:
    """The tree under construction, in creation order: a node's two children are adjacent,
    ``child`` the left one's index (-1 for a leaf)."""

    low: np.ndarray
    high: np.ndarray
    child: np.ndarray
    first: np.ndarray
    count: np.ndarray
    order: np.ndarray  # face indices, grouped by node
    total: int  # nodes made so far

    @classmethod
    def root(cls, bounds: _Bounds, triangles: int) -> _Nodes:
        """Room for the largest tree (``2 F - 1`` nodes), holding the root."""
        capacity = 2 * triangles - 1
        nodes = cls(low=np.empty((capacity, 3)), high=np.empty((capacity, 3)),
                    child=np.full(capacity, -1, dtype=np.int64),
                    first=np.zeros(capacity, dtype=np.int64),
                    count=np.zeros(capacity, dtype=np.int64),
                    order=np.arange(triangles, dtype=np.int64), total=1)
        nodes.low[0], nodes.high[0] = bounds.total()
        nodes.count[0] = triangles
        return nodes

    def split(self, active: np.ndarray, level: _Level, split: _Split) -> np.ndarray:
        """Reorder each active node's triangles left side first and give it two children;
        returns the children, left and right of each node in turn."""
        segment, local, start, count = level.segment, level.local, level.start, level.count
        n_left = split.n_left
        taken = np.cumsum(split.goes_left)
        before = taken[level.offset] - split.goes_left[level.offset]
        rank_left = taken - 1 - before[segment]
        rank_right = local - (taken - before[segment])
        position = start[segment] + np.where(split.goes_left, rank_left,
                                             n_left[segment] + rank_right)
        self.order[position] = level.tris

        rows = np.arange(len(active))
        left = self.total + 2 * rows
        right = left + 1
        self.total += 2 * len(active)
        self.child[active] = left
        self.first[left] = start
        self.count[left] = n_left
        self.first[right] = start + n_left
        self.count[right] = count - n_left
        keep = split.splittable[:, None]
        self.low[left] = np.where(keep, split.left_low, self.low[active])
        self.high[left] = np.where(keep, split.left_high, self.high[active])
        self.low[right] = np.where(keep, split.right_low, self.low[active])
        self.high[right] = np.where(keep, split.right_high, self.high[active])
        self.first[active] = 0
        self.count[active] = 0
        return np.stack([left, right], axis=1).ravel()


def _flatten(nodes: _Nodes, levels: list[np.ndarray], vertices: np.ndarray,
             faces: np.ndarray) -> BVH:
    """The finished tree in the depth-first, sibling-pair layout (see the module docstring)."""
    total = nodes.total
    position = _depth_first_positions(levels, nodes.child[:total])
    node_min, node_max = _outward_float32(nodes.low[:total], nodes.high[:total])
    new = np.empty(total, dtype=np.int64)
    new[position] = np.arange(total)
    child = nodes.child[new]
    node_left = np.where(child >= 0, position[np.maximum(child, 0)], -1)
    return BVH(
        node_min=_readonly(node_min[new]),
        node_max=_readonly(node_max[new]),
        node_left=_readonly(node_left.astype(np.int32)),
        node_first=_readonly(nodes.first[new].astype(np.int32)),
        node_count=_readonly(nodes.count[new].astype(np.int32)),
        triangle_order=_readonly(nodes.order.astype(np.int32)),
        vertices=_readonly(vertices),
        faces=_readonly(faces),
        depth=len(levels) - 1,
    )


def _half_area(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    d = high - low
    return d[..., 0] * d[..., 1] + d[..., 1] * d[..., 2] + d[..., 2] * d[..., 0]


def _depth_first_positions(levels: list[np.ndarray], child: np.ndarray) -> np.ndarray:
    """Final index of every node for the depth-first, sibling-pair layout.

    ``block`` is where a node's child pair goes; the pair is followed by the left child's
    descendants and then the right child's, so ``block(right) = block + 2 + below(left)``
    where ``below`` counts a subtree's nodes excluding its root.
    """
    below = np.zeros(len(child), dtype=np.int64)
    for level in reversed(levels):
        inner = level[child[level] >= 0]
        left = child[inner]
        below[inner] = 2 + below[left] + below[left + 1]
    position = np.zeros(len(child), dtype=np.int64)
    block = np.zeros(len(child), dtype=np.int64)
    block[0] = 1
    for level in levels:
        inner = level[child[level] >= 0]
        left = child[inner]
        position[left] = block[inner]
        position[left + 1] = block[inner] + 1
        block[left] = block[inner] + 2
        block[left + 1] = block[inner] + 2 + below[left]
    return position


def collapse_wide(bvh: BVH, width: int = 4) -> tuple[np.ndarray, np.ndarray, int]:
    """The tree with up to ``width`` children a node, made from ``bvh``'s binary nodes.

    Each wide node stands for an interior binary node: its children start as that node's
    two, and the interior child of largest surface area is replaced by its own two while
    there are fewer than ``width``. Every interior child is a wide node in turn; leaves stay
    the binary tree's (and so does ``triangle_order``). Built level by level with array
    operations.

    Returns
    -------
    children : ndarray, shape (W, width), int64
        Wide node k's children as binary-node indices, -1 in unused slots. Wide node 0 is
        the root's; nodes are numbered breadth-first.
    wide_index : ndarray, shape (N,), int64
        For each binary node that is a wide node, its number; -1 for the others.
    levels : int
        Wide nodes on the longest root-to-leaf path (0 when the root is a leaf).
    """
    interior = bvh.node_count == 0
    size = bvh.node_max.astype(np.float64) - bvh.node_min.astype(np.float64)
    area = size[:, 0] * size[:, 1] + size[:, 1] * size[:, 2] + size[:, 2] * size[:, 0]
    left = bvh.node_left.astype(np.int64)
    wide_index = np.full(bvh.node_total, -1, dtype=np.int64)
    blocks, frontier, total, levels = [], np.array([0] if interior[0] else [], np.int64), 0, 0
    while frontier.size:
        wide_index[frontier] = total + np.arange(frontier.size)
        total += frontier.size
        levels += 1
        members = np.full((frontier.size, width), -1, dtype=np.int64)
        members[:, 0], members[:, 1] = left[frontier], left[frontier] + 1
        rows = np.arange(frontier.size)
        for filled in range(2, width):
            safe = np.maximum(members, 0)
            score = np.where((members >= 0) & interior[safe], area[safe], -np.inf)
            pick = np.argmax(score, axis=1)
            grow = np.isfinite(score[rows, pick])
            r, node = rows[grow], members[rows[grow], pick[grow]]
            members[r, pick[grow]] = left[node]
            members[r, filled] = left[node] + 1
        blocks.append(members)
        inner = members[(members >= 0) & interior[np.maximum(members, 0)]]
        frontier = inner
    children = np.concatenate(blocks) if blocks else np.zeros((0, width), np.int64)
    return children, wide_index, levels
