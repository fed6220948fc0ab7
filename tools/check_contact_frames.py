"""Check a tetsim run's frames from outside: no vertex behind a plane, inside a box or a sphere,
on the wrong side of a mesh obstacle (its nearest triangle's side, the side the body starts on),
or inside another body's tets. Reads the frames with meshio and the scene with tomllib (Python
3.11+), and places the obstacles itself (motions ramp linearly over their duration, as in
tetsim); nothing of tetsim's own summary is used. Self-contact of one body is not checked.

usage: python tools/check_contact_frames.py SCENE.toml OUT_DIR   (pip install meshio numpy)
Prints the smallest gap to each obstacle and the violations; exits 1 when a frame that
steps.csv says converged has one."""
import sys, os, tomllib, glob
import numpy as np, meshio

scene_path, out = sys.argv[1], sys.argv[2]
scene = tomllib.load(open(scene_path, 'rb'))
dt = scene.get('solver', {}).get('dt', 0.01)
frames = sorted(glob.glob(os.path.join(out, 'frame_*.vtu')))
obstacles = scene.get('obstacle', [])


def rot(axis, deg):
    a = np.asarray(axis, float); a /= np.linalg.norm(a); t = np.radians(deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def placement(o, t):
    m = o.get('motion', {}); d = o.get('duration', frames_total * dt)
    s = 1.0 if d <= 0 else min(max(t / d, 0), 1)
    R = rot(m.get('axis', [0, 0, 1]), s * m.get('rotate_degrees', 0.0))
    c = np.asarray(m.get('center', [0, 0, 0]), float)
    T = s * np.asarray(m.get('translate', [0, 0, 0]), float)
    return lambda p: (p - c) @ R.T + c + T, R


def closest_on_triangles(p, a, b, c):
    # Ericson's closest point, vectorised over triangles for one point.
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ap * ab).sum(1), (ap * ac).sum(1)
    bp = p - b; d3, d4 = (bp * ab).sum(1), (bp * ac).sum(1)
    cp = p - c; d5, d6 = (cp * ab).sum(1), (cp * ac).sum(1)
    va = d3 * d6 - d5 * d4; vb = d5 * d2 - d1 * d6; vc = d1 * d4 - d3 * d2
    denom = va + vb + vc; denom[denom == 0] = 1e-300
    v = vb / denom; w = vc / denom
    q = a + ab * v[:, None] + ac * w[:, None]
    cases = [
        ((d1 <= 0) & (d2 <= 0), a),
        ((d3 >= 0) & (d4 <= d3), b),
        ((d6 >= 0) & (d5 <= d6), c),
    ]
    for mask, pt in cases:
        q[mask] = pt[mask]
    m = (vc <= 0) & (d1 >= 0) & (d3 <= 0); t = d1 / np.where(d1 - d3 == 0, 1, d1 - d3)
    q[m] = (a + ab * t[:, None])[m]
    m = (vb <= 0) & (d2 >= 0) & (d6 <= 0); t = d2 / np.where(d2 - d6 == 0, 1, d2 - d6)
    q[m] = (a + ac * t[:, None])[m]
    m = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
    t = (d4 - d3) / np.where((d4 - d3) + (d5 - d6) == 0, 1, (d4 - d3) + (d5 - d6))
    q[m] = (b + (c - b) * t[:, None])[m]
    return q


def inside_tets(points, x, tets):
    # Which points lie strictly inside any tet (barycentric, tolerance 1e-9).
    hit = np.zeros(len(points), bool)
    A = x[tets[:, 1:]] - x[tets[:, :1]]  # (T, 3, 3) rows = edges
    M = np.transpose(A, (0, 2, 1))
    ok = np.abs(np.linalg.det(M)) > 1e-18
    Minv = np.linalg.inv(M[ok]); o = x[tets[ok, 0]]
    lo, hi = x[tets[ok]].min(1), x[tets[ok]].max(1)
    for i, p in enumerate(points):
        near = np.all((p >= lo) & (p <= hi), axis=1)
        if not near.any():
            continue
        l = np.einsum('tij,tj->ti', Minv[near], p - o[near])
        l0 = 1 - l.sum(1)
        if np.any((l > 1e-9).all(1) & (l0 > 1e-9)):
            hit[i] = True
    return hit


frames_total = scene.get('solver', {}).get('frames', len(frames) - 1)
worst = {}
bad = []
for f, path in enumerate(frames):
    m = meshio.read(path); x = m.points; t = f * dt
    tets = m.cells_dict['tetra']
    body = m.point_data.get('body')
    for k, o in enumerate(obstacles):
        name = o.get('name', f'obstacle {k + 1}')
        move, R = placement(o, t)
        if 'plane' in o:
            p0 = move(np.asarray(o['plane']['point'], float)); n = R @ np.asarray(o['plane']['normal'], float)
            g = (x - p0) @ (n / np.linalg.norm(n)); gmin = g.min()
        elif 'box' in o:
            lo, hi = np.asarray(o['box']['min'], float), np.asarray(o['box']['max'], float)
            c0 = 0.5 * (lo + hi); c1 = move(c0)
            local = (x - c1) @ R + c0  # back into the box's own frame
            depth = np.minimum(local - lo, hi - local).min(1)  # > 0 inside
            gmin = -depth.max()
        elif 'sphere' in o:
            c = move(np.asarray(o['sphere']['center'], float)); r = o['sphere']['radius']
            gmin = (np.linalg.norm(x - c, axis=1) - r).min()
        elif 'mesh' in o:
            mm = meshio.read(os.path.join(os.path.dirname(scene_path), o['mesh']))
            y = move(mm.points.astype(float)); tri = mm.cells_dict['triangle']
            a, b, c = y[tri[:, 0]], y[tri[:, 1]], y[tri[:, 2]]
            n = np.cross(b - a, c - a); n /= np.linalg.norm(n, axis=1)[:, None]
            gs = []
            for p in x:
                q = closest_on_triangles(p, a, b, c)
                d = np.linalg.norm(q - p, axis=1); j = d.argmin()
                s = np.sign((p - q[j]) @ n[j]) if d[j] > 0 else 0.0
                gs.append(s * d[j])
            gs = np.array(gs)
            # The side the body starts on is "outside".
            side = worst.setdefault(('side', k), np.sign(np.median(gs)))
            gmin = (side * gs).min()
        else:
            continue
        worst[name] = min(worst.get(name, np.inf), gmin)
        if gmin <= 0:
            bad.append((f, name, gmin))
    if body is not None:
        ids = np.unique(body)
        tb = body[tets[:, 0]]
        for i in ids:
            for j in ids:
                if i == j:
                    continue
                pts = x[body == i]
                h = inside_tets(pts, x, tets[tb == j])
                if h.any():
                    bad.append((f, f'body {int(i)} in body {int(j)}', int(h.sum())))
# A frame may say it did not converge; it may not say `converged` with a vertex inside anything.
import csv
said = {int(r['frame']): r['converged'] == 'true'
        for r in csv.DictReader(open(os.path.join(out, 'steps.csv')))}
lies = [b for b in bad if said.get(b[0], True)]
print(os.path.basename(out), 'frames', len(frames),
      'min gaps', {k: float(v) for k, v in worst.items() if isinstance(k, str)},
      'violations', len(bad), 'in frames said converged', len(lies), bad[:5])
sys.exit(1 if lies else 0)
