"""Motion planning for a robot translating in the plane among polygonal obstacles: configuration
space obstacles, regular (quadtree) cell decomposition with its adjacency graph, and the
generalized Voronoi diagram as a roadmap (retraction), with shortest paths on the graphs.

- C-obstacles: a convex robot translating with a reference point r sweeps the obstacle O into
  O (+) (-(R - r)): the convex hull of the sums of the vertices (obstacles convex).
- Quadtree: a square cell is free (no overlap with the interior of a C-obstacle), occupied
  (inside one) or mixed (split in four, top-left, top-right, bottom-left, bottom-right) down to a
  smallest size, where mixed counts as occupied. Free cells are numbered from 1 in that
  depth-first order; two are adjacent when they share a piece of side of positive length.
- Voronoi roadmap: on a grid, the points with two nearest obstacles (points, segments, the walls)
  at the same distance; start and goal are retracted onto it moving away from their nearest
  obstacle.

>>> cells = quadtree((0, 0, 8), [[(2, 2), (4, 2), (4, 4), (2, 4)]], min_size=2)
>>> [(c.x, c.y, c.size) for c in cells][:3]     # exact: halvings of the root square
[(0.0, 4.0, 4.0), (4.0, 4.0, 4.0), (0.0, 2.0, 2.0)]
>>> sorted({round(w, 4) for _a, _b, w in adjacency(cells)})
[2.0, 3.1623, 4.0]
"""
from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .errors import UserError

Point = Tuple[float, float]


class PlanningError(UserError):
    """Bad planning data (obstacle not convex, start inside an obstacle, no path)."""


# ====================================================================== geometry
def _convex_hull(points: Sequence[Point]) -> List[Point]:
    """Counterclockwise hull (monotone chain)."""
    pts = sorted(set((float(x), float(y)) for x, y in points))
    if len(pts) <= 2:
        return pts

    def half(seq):
        out: List[Point] = []
        for p in seq:
            while len(out) >= 2 and _cross(out[-2], out[-1], p) <= 1e-12:
                out.pop()
            out.append(p)
        return out
    lower, upper = half(pts), half(reversed(pts))
    return lower[:-1] + upper[:-1]


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def is_convex(poly: Sequence[Point]) -> bool:
    return len(_convex_hull(poly)) == len(set(map(tuple, poly)))


def c_obstacle(obstacle: Sequence[Point], robot: Sequence[Point], reference: Point) -> List[Point]:
    """The C-obstacle of a convex obstacle for a convex robot translating with ``reference``:
    obstacle (+) (reference - robot), as a counterclockwise polygon.

    >>> c_obstacle([(2, 2), (4, 2), (4, 4), (2, 4)], [(0, 0), (1, 0), (1, 1), (0, 1)], (0, 0))  # exact sums
    [(1.0, 1.0), (4.0, 1.0), (4.0, 4.0), (1.0, 4.0)]
    """
    if not is_convex(obstacle) or not is_convex(robot):
        raise PlanningError("obstacles and robot must be convex polygons (split a non-convex one)")
    return _convex_hull([(ox + reference[0] - rx, oy + reference[1] - ry)
                         for ox, oy in obstacle for rx, ry in robot])


def _overlaps_square(poly: Sequence[Point], x: float, y: float, s: float) -> bool:
    """Whether a convex polygon and the square [x, x+s] x [y, y+s] share interior points
    (separating axes: the square's two axes and the polygon's edge normals)."""
    sq = [(x, y), (x + s, y), (x + s, y + s), (x, y + s)]
    axes = [(1.0, 0.0), (0.0, 1.0)]
    for a, b in zip(poly, list(poly[1:]) + [poly[0]]):
        axes.append((b[1] - a[1], a[0] - b[0]))
    for ax in axes:
        p1 = [ax[0] * px + ax[1] * py for px, py in poly]
        p2 = [ax[0] * px + ax[1] * py for px, py in sq]
        if max(p1) <= min(p2) + 1e-12 or max(p2) <= min(p1) + 1e-12:
            return False
    return True


def _inside(poly: Sequence[Point], p: Point) -> bool:
    """Point inside or on a counterclockwise convex polygon."""
    return all(_cross(a, b, p) >= -1e-12 for a, b in zip(poly, list(poly[1:]) + [poly[0]]))


# ====================================================================== quadtree
@dataclass
class Cell:
    x: float
    y: float
    size: float
    number: int = 0

    @property
    def center(self) -> Point:
        return (self.x + self.size / 2, self.y + self.size / 2)

    def contains(self, p: Point) -> bool:
        return self.x <= p[0] <= self.x + self.size and self.y <= p[1] <= self.y + self.size


def quadtree(root: Tuple[float, float, float], cobstacles: Sequence[Sequence[Point]], min_size: float) -> List[Cell]:
    """Free cells of the regular decomposition of the square root = (x, y, side), numbered from 1
    depth-first (top-left, top-right, bottom-left, bottom-right)."""
    polys = [_convex_hull(p) for p in cobstacles]
    free: List[Cell] = []

    def visit(x, y, s):
        hit = [p for p in polys if _overlaps_square(p, x, y, s)]
        if not hit:
            free.append(Cell(float(x), float(y), float(s)))
            return
        corners = [(x, y), (x + s, y), (x + s, y + s), (x, y + s)]
        if any(all(_inside(p, c) for c in corners) for p in hit) or s / 2 < min_size - 1e-12:
            return                         # occupied, or mixed at the smallest size
        h = s / 2
        for cx, cy in ((x, y + h), (x + h, y + h), (x, y), (x + h, y)):
            visit(cx, cy, h)
    if min_size <= 0:
        raise PlanningError("the smallest cell size must be positive")
    visit(*root)
    for k, c in enumerate(free, 1):
        c.number = k
    return free


def adjacency(cells: Sequence[Cell]) -> List[Tuple[int, int, float]]:
    """Edges (number, number, distance between the centers) of cells sharing a piece of side."""
    edges = []
    for a, b in itertools.combinations(cells, 2):
        ox = min(a.x + a.size, b.x + b.size) - max(a.x, b.x)
        oy = min(a.y + a.size, b.y + b.size) - max(a.y, b.y)
        if (abs(ox) < 1e-12 and oy > 1e-12) or (abs(oy) < 1e-12 and ox > 1e-12):
            edges.append((a.number, b.number, float(np.hypot(a.center[0] - b.center[0], a.center[1] - b.center[1]))))
    return edges


# ====================================================================== graphs
def shortest_path(edges, start, goal, heuristic=None) -> Tuple[float, List, int]:
    """A* (Dijkstra without ``heuristic``): (length, nodes, expanded nodes); length inf when the
    goal cannot be reached."""
    graph: Dict[object, List[Tuple[object, float]]] = {}
    for a, b, w in edges:
        graph.setdefault(a, []).append((b, w))
        graph.setdefault(b, []).append((a, w))
    h = heuristic or (lambda node: 0.0)
    best = {start: 0.0}
    prev: Dict[object, object] = {}
    heap = [(h(start), 0.0, 0, start)]
    counter = itertools.count(1)
    done = set()
    while heap:
        _f, g, _k, node = heapq.heappop(heap)
        if node in done:
            continue
        done.add(node)
        if node == goal:
            path = [node]
            while path[-1] != start:
                path.append(prev[path[-1]])
            return g, path[::-1], len(done)
        for nb, w in graph.get(node, []):
            ng = g + w
            if ng < best.get(nb, np.inf) - 1e-12:
                best[nb], prev[nb] = ng, node
                heapq.heappush(heap, (ng + h(nb), ng, next(counter), nb))
    return float("inf"), [], len(done)


def channels(edges, start, goal, limit: int = 10000) -> List[List]:
    """Every simple path (no repeated node) from start to goal, at most ``limit`` of them."""
    graph: Dict[object, List[object]] = {}
    for a, b, _w in edges:
        graph.setdefault(a, []).append(b)
        graph.setdefault(b, []).append(a)
    out: List[List] = []

    def walk(path):
        if len(out) >= limit:
            return
        if path[-1] == goal:
            out.append(list(path))
            return
        for nb in sorted(graph.get(path[-1], []), key=str):
            if nb not in path:
                path.append(nb)
                walk(path)
                path.pop()
    walk([start])
    return out


# ====================================================================== Voronoi roadmap
def _segment_distance(P: np.ndarray, a: Point, b: Point) -> np.ndarray:
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    t = np.clip(((P - a) @ d) / max(float(d @ d), 1e-300), 0.0, 1.0)
    return np.linalg.norm(P - (a + t[:, None] * d), axis=1)


@dataclass
class VoronoiRoadmap:
    step: float
    nodes: np.ndarray            # grid points of the roadmap
    clearance: np.ndarray        # their distance from the nearest obstacle
    edges: List[Tuple[int, int, float]]


def voronoi_roadmap(room: Tuple[float, float, float, float], points: Sequence[Point],
                    polygons: Sequence[Sequence[Point]] = (), step: float = 0.05) -> VoronoiRoadmap:
    """Generalized Voronoi diagram of point and polygonal obstacles in a rectangular room
    (x0, y0, x1, y1) on a grid of spacing ``step``: the grid points whose two nearest obstacles
    (each point, each polygon, each wall) are within one step of the same distance."""
    x0, y0, x1, y1 = room
    if not (x1 > x0 and y1 > y0) or step <= 0:
        raise PlanningError("room: expected x0 < x1, y0 < y1 and a positive step")
    xs, ys = np.arange(x0, x1 + step / 2, step), np.arange(y0, y1 + step / 2, step)
    if len(xs) * len(ys) > 400000:
        raise PlanningError("the grid is too fine for the room (at most 400000 points)")
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    P = np.column_stack([X.ravel(), Y.ravel()])
    walls = [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]
    dists = [np.linalg.norm(P - np.asarray(p, float), axis=1) for p in points]
    for poly in polygons:
        dists.append(np.min([_segment_distance(P, a, b) for a, b in zip(poly, list(poly[1:]) + [poly[0]])], axis=0))
    dists += [_segment_distance(P, a, b) for a, b in walls]
    D = np.sort(np.vstack(dists), axis=0)
    ridge = (D[1] - D[0] <= step) & (D[0] > step)
    idx = -np.ones(X.shape, dtype=int)
    flat = np.flatnonzero(ridge)
    idx.ravel()[flat] = np.arange(len(flat))
    edges = []
    shape = X.shape
    for k, f in enumerate(flat):
        i, j = divmod(int(f), shape[1])
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            a, b = i + di, j + dj
            if 0 <= a < shape[0] and 0 <= b < shape[1] and idx[a, b] >= 0:
                edges.append((k, int(idx[a, b]), step * float(np.hypot(di, dj))))
    # the diagram runs between the grid point's two nearest obstacles: mean of the two distances
    return VoronoiRoadmap(step, P[flat], (D[0][flat] + D[1][flat]) / 2, edges)


def retract(roadmap: VoronoiRoadmap, nearest_obstacle_point: np.ndarray, p: Point) -> int:
    """The roadmap node reached from p moving straight away from its nearest obstacle point."""
    p = np.asarray(p, float)
    d = p - nearest_obstacle_point
    norm = float(np.linalg.norm(d))
    if norm < 1e-12:
        raise PlanningError("the point lies on an obstacle")
    d /= norm
    rel = roadmap.nodes - p
    along = rel @ d
    across = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0])
    ok = (along >= -roadmap.step) & (across <= roadmap.step)
    if not ok.any():
        raise PlanningError("the retraction meets no roadmap point")
    cand = np.flatnonzero(ok)
    return int(cand[np.argmin(along[cand])])


def nearest_obstacle_point(room, points, polygons, p: Point) -> np.ndarray:
    """The point of the obstacles (points, polygon edges, walls) nearest to p."""
    x0, y0, x1, y1 = room
    p = np.asarray(p, float)
    segs = [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]
    for poly in polygons:
        segs += list(zip(poly, list(poly[1:]) + [poly[0]]))
    cands = [np.asarray(q, float) for q in points]
    for a, b in segs:
        a, b = np.asarray(a, float), np.asarray(b, float)
        t = float(np.clip((p - a) @ (b - a) / max(float((b - a) @ (b - a)), 1e-300), 0.0, 1.0))
        cands.append(a + t * (b - a))
    return min(cands, key=lambda c: float(np.linalg.norm(p - c)))
