"""Sweep: the ``blob`` mesher (``codermind.blobmesh.build_blob_mesh``, what the
``blob`` plugin builds) on two sources as their distance D approaches 2 sqrt(2) R, where the
neck between them pinches off.

The field's true topology is known in closed form for both fields: the saddle is the midpoint,
where two sources give 2 f((D/2)^2 / R^2) (tutorial) or 8 R^2 / D^2 (exact); both equal 1 at
D = 2 sqrt(2) R, and the neck radius is R sqrt(2 - D^2 / (4 R^2)) for both (the tutorial's f
is exactly 1/x at the zone boundary x = 2). Beyond, the gap between the two surfaces along
the axis is found by bisection. Measured per mesh: connected components, watertightness and
orientation (every edge in exactly two faces, in opposite directions), the Euler
characteristic of each component (2: a sphere), and the neck radius where the mesh crosses the
mid-plane.
"""

from __future__ import annotations

import math

import numpy as np

from codermind_ref.blob import field as zone_f

from .sweep_result import Plan, Series, SweepResult, finite_check_counts, finite_counts

CRITICAL = 2.0 * math.sqrt(2.0)          # D / R where the neck closes


def _true_neck(d: float) -> float:
    """Neck radius / R of two sources at distance d R (0 beyond the critical distance)."""
    return math.sqrt(max(2.0 - d * d / 4.0, 0.0))


def _true_gap(d: float, field: str) -> float:
    """Gap / R between the two surfaces along the axis (0 while connected)."""
    if d <= CRITICAL:
        return 0.0
    total = (lambda a: float(zone_f(a * a)) + float(zone_f((d - a) ** 2))) if field == "tutorial" \
        else (lambda a: 1.0 / (a * a) + 1.0 / ((d - a) ** 2))
    lo, hi = 0.5, d / 2                       # total(lo) > 1 > total(hi)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if total(mid) > 1.0 else (lo, mid)
    return d - 2.0 * lo


def _topology(v: np.ndarray, f: np.ndarray) -> dict:
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    undirected = np.sort(directed, axis=1)
    edges, counts = np.unique(undirected, axis=0, return_counts=True)
    watertight = bool((counts == 2).all())
    oriented = len(np.unique(directed, axis=0)) == len(directed)      # no edge twice one way
    n = len(v)
    graph = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    euler = []
    for c in range(count):
        vc = int((label == c).sum())
        fc = int((label[f[:, 0]] == c).sum())
        ec = int((label[edges[:, 0]] == c).sum())
        euler.append(vc - ec + fc)
    return {"components": int(count), "watertight": watertight, "oriented": bool(oriented),
            "euler": euler}


def _mesh_neck(v: np.ndarray, f: np.ndarray, x_mid: float) -> float:
    """Mean distance from the axis of the mesh's crossings of the mid-plane (0: none)."""
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1),
                  axis=0)
    a, b = v[e[:, 0]], v[e[:, 1]]
    cross = (a[:, 0] - x_mid) * (b[:, 0] - x_mid) < 0
    if not cross.any():
        return 0.0
    a, b = a[cross], b[cross]
    t = (x_mid - a[:, 0]) / (b[:, 0] - a[:, 0])
    p = a + t[:, None] * (b - a)
    return float(np.hypot(p[:, 1], p[:, 2]).mean())


ERRORS = (1 / 500, 1 / 50)        # max_error / R: the plugin's default, and coarse
FIELDS = ("tutorial", "exact")


def _offsets(quick: bool) -> list[float]:
    return [-0.3, -0.1, -0.03, -0.01, -0.003, -0.001, -0.0003, -0.0001, 0.0001, 0.001, 0.01,
            0.03, 0.1] if not quick else [-0.1, -0.01, -0.001, 0.001, 0.01, 0.1]


def _mesh_point(p: tuple) -> dict:
    """(field, max_error, D): one mesh, its row of the table and the finiteness of its
    vertices."""
    from codermind.blobmesh import build_blob_mesh
    field, err, d = p
    mesh = build_blob_mesh(np.array([[0.0, 0.0, 0.0], [d, 0.0, 0.0]]), 1.0, field, err)
    v, f = mesh.vertices, mesh.faces
    topo = _topology(v, f)
    true_components = 1 if d < CRITICAL else 2
    neck, gap = _true_neck(d), _true_gap(d, field)
    measured = _mesh_neck(v, f, d / 2)
    h = float(mesh.info.get("cell_size", float("nan")))
    reported = mesh.achieved_error > err or bool(mesh.info.get("lost_necks"))
    row = {"field": field, "max_error": err, "D": d, "true_neck": neck,
           "true_gap": gap, "true_components": true_components,
           "mesh_neck": measured, **topo, "cell_size": h,
           "achieved_error": float(mesh.achieved_error),
           "lost_necks": list(mesh.info.get("lost_necks", [])),
           "reported": reported, "triangles": int(len(f))}
    return {"row": row, "finite": finite_counts(v)}


def blob_neck(quick: bool = False) -> Plan:
    """Points: one mesh per field, max_error and distance; then (a second round) the
    picture of the mesh closest to pinching off that kept its topology."""
    offsets = _offsets(quick)
    points = [(field, err, CRITICAL + off) for field in FIELDS for err in ERRORS
              for off in offsets]
    return Plan(points, _mesh_point, lambda results: _assemble(offsets, results))


def _assemble(offsets: list[float], results: list[dict]) -> Plan:
    errors, fields = list(ERRORS), list(FIELDS)
    rows = [x["row"] for x in results]
    r = SweepResult(
        "blob_neck", "blob mesher vs neck thickness (two sources at distance D)",
        parameter=f"D / R from {CRITICAL + offsets[0]:.4f} to {CRITICAL + offsets[-1]:.4f} "
                  f"around 2 sqrt(2) = {CRITICAL:.5f}; fields tutorial and exact; max_error "
                  f"R/500 (default) and R/50",
        measured="mesh components vs the field's, watertight and oriented, Euler "
                 "characteristic per component, neck radius at the mid-plane",
        threshold="", threshold_value=None, xlabel="true neck radius / R (negative: gap / 2)",
        ylabel="mesh neck radius / R", xlog=False, ylog=False)
    k = len(offsets)
    for i, (field, err) in enumerate((f, e) for f in fields for e in errors):
        mine = rows[i * k:(i + 1) * k]
        xs = [row["true_neck"] if row["D"] < CRITICAL else -row["true_gap"] / 2 for row in mine]
        r.series.append(Series(f"{field}, max_error R/{round(1 / err)}", xs,
                               [row["mesh_neck"] for row in mine]))
    r.series.append(Series("true neck", list(r.series[0].x),
                           [max(x, 0.0) for x in r.series[0].x], "--", "k"))
    r.table = rows
    finite_check_counts(r, "vertices finite", [x["finite"] for x in results])
    r.check("every mesh watertight and consistently oriented",
            all(row["watertight"] and row["oriented"] for row in rows),
            "; ".join(f"{row['field']} D {row['D']:.5f}" for row in rows
                      if not (row["watertight"] and row["oriented"])))
    r.check("every component a sphere (Euler characteristic 2)",
            all(all(e == 2 for e in row["euler"]) for row in rows),
            "; ".join(f"{row['field']} D {row['D']:.5f}: {row['euler']}" for row in rows
                      if not all(e == 2 for e in row["euler"])))
    # where the neck or gap is at least two first cells wide the answer is unambiguous
    clear = [row for row in rows if max(row["true_neck"], row["true_gap"] / 2) >= 2 * row["cell_size"]]
    wrong = [row for row in clear if row["components"] != row["true_components"]]
    r.check("true topology wherever the neck or half-gap is >= 2 cells",
            not wrong, "; ".join(f"{w['field']} R/{round(1 / w['max_error'])} D "
                                 f"{w['D']:.5f}: {w['components']} components" for w in wrong))
    lost = [row for row in rows if row["components"] != row["true_components"]]
    silent = [row for row in lost if not row["reported"]]
    r.check("a wrong topology is never silent (error above max_error, or a lost neck named)",
            not silent, "; ".join(f"{w['field']} R/{round(1 / w['max_error'])} D {w['D']:.5f}: "
                                  f"{w['components']} components, error "
                                  f"{w['achieved_error']:.3g}" for w in silent))
    parts = []
    for field in fields:
        for err in errors:
            mine = [row for row in rows if row["field"] == field and row["max_error"] == err]
            kept = [row["true_neck"] for row in mine
                    if row["true_components"] == 1 and row["components"] == 1]
            missed = [row["true_neck"] for row in mine
                      if row["true_components"] == 1 and row["components"] != 1]
            bridged = [row["true_gap"] for row in mine
                       if row["true_components"] == 2 and row["components"] != 2]
            h = mine[0]["cell_size"]
            parts.append(f"{field} R/{round(1 / err)} (cell {h:.3g} R): thinnest neck kept "
                         f"{min(kept):.3g} R" + (f", thickest lost {max(missed):.3g} R"
                                                 if missed else ", none lost") +
                         (f", gap up to {max(bridged):.3g} R bridged" if bridged else ""))
    r.threshold = "; ".join(parts) + f"; {len(lost)} of {len(rows)} meshes with the wrong " \
        f"number of components, all within 2 cells of the pinch and reported"
    r.threshold_value = min(row["true_neck"] for row in rows
                            if row["true_components"] == 1 and row["components"] == 1)
    r.lines = [("x", 0.0, "pinch-off")]
    row = _pictured(rows)

    def finish(picture: list) -> SweepResult:
        r.image, r.image_title = picture[0] if picture else (None, "")
        return r
    return Plan([row] if row is not None else [], _picture, finish)


def _pictured(rows) -> dict | None:
    """The mesh closest to pinching off that still has the true (one-piece) topology."""
    ok = [row for row in rows if row["true_components"] == 1 and row["components"] == 1
          and row["max_error"] == rows[0]["max_error"] and row["field"] == "tutorial"]
    return min(ok, key=lambda r: r["true_neck"]) if ok else None


def _picture(row: dict) -> tuple[np.ndarray, str]:
    """The mesh of ``row`` (see :func:`_pictured`) drawn as its silhouette around the neck
    (x-y plane, 200 x 100)."""
    from codermind.blobmesh import build_blob_mesh
    d = row["D"]
    mesh = build_blob_mesh(np.array([[0.0, 0.0, 0.0], [d, 0.0, 0.0]]), 1.0, "tutorial",
                           row["max_error"])
    v, f = mesh.vertices, mesh.faces
    w, h = 200, 100
    xs = np.linspace(d / 2 - 1.0, d / 2 + 1.0, w)
    ys = np.linspace(0.5, -0.5, h)
    img = np.zeros((h, w))
    # rasterize the triangles' x-y projections (a silhouette: any triangle covering a pixel)
    tri = v[f][:, :, :2]
    for t in tri:
        x0, x1 = t[:, 0].min(), t[:, 0].max()
        if x1 < xs[0] or x0 > xs[-1]:
            continue
        i0, i1 = np.searchsorted(xs, [x0, x1])
        j0, j1 = np.searchsorted(-ys, [-t[:, 1].max(), -t[:, 1].min()])
        if i1 <= i0 or j1 <= j0:
            continue
        gx, gy = np.meshgrid(xs[i0:i1], ys[j0:j1])
        (ax, ay), (bx, by), (cx, cy) = t
        den = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
        if den == 0:
            continue
        l1 = ((by - cy) * (gx - cx) + (cx - bx) * (gy - cy)) / den
        l2 = ((cy - ay) * (gx - cx) + (ax - cx) * (gy - cy)) / den
        inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        img[j0:j1, i0:i1] = np.maximum(img[j0:j1, i0:i1], inside)
    return img, (f"silhouette at the neck, D = {d:.5f} R (true neck {row['true_neck']:.3g} R, "
                 f"mesh {row['mesh_neck']:.3g} R)")
