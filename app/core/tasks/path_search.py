"""Motion planning tasks for a robot translating in the plane among obstacles (core:
app.core.roadmap). Points are [x, y] lists; polygons lists of points (convex, counterclockwise or
not).

``cell_decomposition``: ``workspace`` [x0, y0, side] (the square of configurations of the
  reference point), ``obstacles`` (polygons), ``robot`` (its polygon, default the unit square) and
  ``reference`` (its point that represents it, default [0, 0]), ``min_size`` (smallest cell side),
  ``start``, ``goal`` (positions of the reference point), ``channel_limit`` (default 1000).
  Answers ``c_obstacle_<k>`` (vertices), ``cells`` (rows x, y, side of the free cells, numbered from 1 in the
  order of the rows), ``cell_count``, ``edges`` (rows i, j, length), ``edge_count``,
  ``edge_weights`` (the distinct lengths between cell centers), ``start_cell``, ``goal_cell``,
  ``channels`` (the simple paths of cells, as rows padded with 0) and ``channel_count``, ``path``
  (the shortest channel, Dijkstra on center distances), ``path_length``, ``astar_path``,
  ``astar_length`` (A* with the Euclidean distance to the goal cell's center),
  ``astar_expanded``, ``dijkstra_expanded``.
``voronoi_roadmap``: ``room`` [x0, y0, x1, y1], ``points`` (point obstacles), ``polygons``,
  ``start``, ``goal``, ``step`` (grid spacing, default 0.05). Answers ``node_count``,
  ``start_retraction``, ``goal_retraction`` (where the retraction meets the roadmap),
  ``roadmap_length`` (the path on the roadmap, as a polyline through every 10th point),
  ``path_length`` (with the two retraction segments), ``bottleneck`` (smallest clearance along the
  roadmap path), ``path`` (rows x, y).

Example (2004-04-06#1): ``{kind: cell_decomposition, workspace: [0, 0, 8], obstacles:
[[[1, 5], [2, 5], [2, 7], [1, 7]]], min_size: 2, start: [3, 7.5], goal: [1, 1]}``.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .. import roadmap as rm
from ..latex import num
from . import task
from .context import TaskView

UNIT_SQUARE = [[0, 0], [1, 0], [1, 1], [0, 1]]


def _points(d, raw, where: str):
    arr = d.array(raw, where)
    arr = np.atleast_2d(arr)
    if arr.shape[1] != 2:
        raise d._fail(f"{where}: expected [x, y] points")
    return [tuple(float(v) for v in row) for row in arr]


def _polygons(d, raw, where: str):
    if raw is None:
        return []
    if not isinstance(raw, list):
        raise d._fail(f"{where}: expected a list of polygons")
    return [_points(d, p, f"{where}[{i}]") for i, p in enumerate(raw)]


def _exact(x: float):
    """A length as an exact number when it is the square root of an integer (cell centers)."""
    r = round(x * x)
    return sp.sqrt(r) if abs(x * x - r) < 1e-9 else x


def _highlight(points, labels=None):
    return [{"label": (labels[i] if labels else str(i + 1)), "position": [float(p[0]), float(p[1]), 0.0]}
            for i, p in enumerate(points)]


@task("cell_decomposition")
def cell_decomposition_task(ctx, spec):
    """Regular cell decomposition, adjacency graph, channels and shortest path (module docstring)."""
    d = TaskView(ctx)
    ws = d.array(spec.get("workspace"), "cell_decomposition.workspace").reshape(-1)
    if ws.size != 3 or ws[2] <= 0:
        raise d._fail("cell_decomposition.workspace: expected [x0, y0, side]")
    robot = _points(d, spec.get("robot", UNIT_SQUARE), "cell_decomposition.robot")
    ref = _points(d, spec.get("reference", [0, 0]), "cell_decomposition.reference")[0]
    obstacles = _polygons(d, spec.get("obstacles"), "cell_decomposition.obstacles")
    min_size = d.number(spec.get("min_size", ws[2] / 8), "cell_decomposition.min_size")
    try:
        cobs = [rm.c_obstacle(o, robot, ref) for o in obstacles]
        cells = rm.quadtree(tuple(ws), cobs, min_size)
    except rm.PlanningError as exc:
        raise d._fail(f"cell_decomposition: {exc}") from None
    ctx.step("C-obstacles", r",\ ".join(r"\mathrm{conv}\{" + ", ".join(f"({num(x)}, {num(y)})" for x, y in c) + r"\}" for c in cobs),
             "The robot becomes its reference point; each obstacle grows by the robot's shape reflected "
             "about that point (Minkowski sum).", points=_highlight([p for c in cobs for p in c]))
    rows = sp.Matrix([[c.x, c.y, c.size] for c in cells]) if cells else sp.zeros(0, 3)
    ctx.step("Regular cell decomposition", r"\text{free cells } (x, y, \text{side}):\ " + ",\\ ".join(
             f"{c.number}: ({num(c.x)}, {num(c.y)}, {num(c.size)})" for c in cells),
             f"Squares split in four while mixed, down to side {num(min_size)} where mixed counts as occupied; "
             "free cells numbered depth-first (top-left, top-right, bottom-left, bottom-right).",
             points=_highlight([c.center for c in cells], [str(c.number) for c in cells]))
    edges = rm.adjacency(cells)
    weights = sorted({_exact(w) for _a, _b, w in edges}, key=float)
    ctx.step("Adjacency graph", r",\ ".join(f"{a}-{b}: {sp.latex(_exact(w))}" for a, b, w in edges),
             f"{len(cells)} nodes, {len(edges)} arcs, weighted by the distance between the cell centers "
             "(a collision-free segment).")
    for k, c in enumerate(cobs, 1):
        ctx.answer(f"c_obstacle_{k}", sp.Matrix(c))
    for key, value in (("cells", rows), ("cell_count", len(cells)),
                       ("edges", sp.Matrix([[a, b, _exact(w)] for a, b, w in edges]) if edges else sp.zeros(0, 3)),
                       ("edge_count", len(edges)), ("edge_weights", weights)):
        ctx.answer(key, value)
    if "start" not in spec or "goal" not in spec:
        return
    start = _points(d, spec["start"], "cell_decomposition.start")[0]
    goal = _points(d, spec["goal"], "cell_decomposition.goal")[0]
    s = next((c for c in cells if c.contains(start)), None)
    g = next((c for c in cells if c.contains(goal)), None)
    if s is None or g is None:
        raise d._fail("cell_decomposition: the start or the goal is not in a free cell")
    limit = int(spec.get("channel_limit", 1000))
    chans = rm.channels(edges, s.number, g.number, limit)
    length, path, expanded = rm.shortest_path(edges, s.number, g.number)
    if not path:
        raise d._fail("cell_decomposition: no channel joins the start and goal cells")
    centers = {c.number: c.center for c in cells}
    h = lambda k: float(np.hypot(centers[k][0] - g.center[0], centers[k][1] - g.center[1]))
    a_len, a_path, a_exp = rm.shortest_path(edges, s.number, g.number, h)
    width = max(len(c) for c in chans)
    ctx.step("Channels", r",\ ".join(r"\{" + ", ".join(map(str, c)) + r"\}" for c in chans),
             f"{len(chans)} channels (paths without cycles) from cell {s.number} (start) to cell {g.number} (goal).")
    ctx.step("Shortest channel", rf"\{{{', '.join(map(str, path))}\}},\quad L = {sp.latex(sp.nsimplify(length, [sp.sqrt(2), sp.sqrt(5), sp.sqrt(10)]))}",
             f"Dijkstra on the weighted graph; A-star with the Euclidean distance to the goal cell's center (admissible) "
             f"finds the same length expanding {a_exp} nodes instead of {expanded}.",
             path=[[centers[k][0], centers[k][1], 0.0] for k in path])
    for key, value in (("start_cell", s.number), ("goal_cell", g.number),
                       ("channels", sp.Matrix([c + [0] * (width - len(c)) for c in chans])),
                       ("channel_count", len(chans)), ("path", path), ("path_length", length),
                       ("astar_path", a_path), ("astar_length", a_len), ("astar_expanded", a_exp),
                       ("dijkstra_expanded", expanded)):
        ctx.answer(key, value)


@task("voronoi_roadmap")
def voronoi_roadmap_task(ctx, spec):
    """Generalized Voronoi roadmap, retraction of start and goal, shortest path (module docstring)."""
    d = TaskView(ctx)
    room = tuple(d.array(spec.get("room"), "voronoi_roadmap.room").reshape(-1))
    points = _points(d, spec.get("points", []), "voronoi_roadmap.points") if spec.get("points") else []
    polygons = _polygons(d, spec.get("polygons"), "voronoi_roadmap.polygons")
    step = d.number(spec.get("step", 0.05), "voronoi_roadmap.step")
    try:
        R = rm.voronoi_roadmap(room, points, polygons, step)
        ends = []
        for key in ("start", "goal"):
            p = _points(d, spec[key], f"voronoi_roadmap.{key}")[0]
            near = rm.nearest_obstacle_point(room, points, polygons, p)
            ends.append((p, rm.retract(R, near, p)))
    except (rm.PlanningError, KeyError) as exc:
        raise d._fail(f"voronoi_roadmap: {exc}") from None
    (S, si), (G, gi) = ends
    length, path, _exp = rm.shortest_path(R.edges, si, gi)
    if not path:
        raise d._fail("voronoi_roadmap: start and goal retract onto disconnected parts of the roadmap")
    pts = R.nodes[path]
    keep = sorted(set(list(range(0, len(pts), 10)) + [len(pts) - 1]))
    poly = pts[keep]
    road = float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
    total = road + float(np.linalg.norm(R.nodes[si] - S)) + float(np.linalg.norm(R.nodes[gi] - G))
    bottleneck = float(R.clearance[path].min())
    ctx.step("Generalized Voronoi diagram", rf"{len(R.nodes)}\ \text{{grid points with two nearest obstacles at the same distance (step {num(step)})}}",
             "Points equidistant from the two nearest obstacles (points, polygons, walls): the paths of largest clearance.",
             points=_highlight([*points], [f"O{i + 1}" for i in range(len(points))]))
    ctx.step("Retraction", rf"S = ({num(S[0])}, {num(S[1])}) \to ({num(R.nodes[si][0])}, {num(R.nodes[si][1])}),\quad "
             rf"G = ({num(G[0])}, {num(G[1])}) \to ({num(R.nodes[gi][0])}, {num(R.nodes[gi][1])})",
             "Start and goal move straight away from their nearest obstacle until they reach the diagram.")
    ctx.step("Path on the roadmap", rf"L = {num(total, 3)},\quad \min\ \text{{clearance}} = {num(bottleneck, 3)}",
             "Shortest path on the graph of the diagram (a polyline through its points), plus the two retractions.",
             path=[[float(x), float(y), 0.0] for x, y in [S, *poly.tolist(), G]])
    for key, value in (("node_count", len(R.nodes)), ("start_retraction", R.nodes[si]), ("goal_retraction", R.nodes[gi]),
                       ("roadmap_length", road), ("path_length", total), ("bottleneck", bottleneck), ("path", poly)):
        ctx.answer(key, value)
