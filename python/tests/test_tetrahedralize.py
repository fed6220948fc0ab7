"""tetrahedralize: a surface given as numpy arrays comes back as a tet mesh of its solid."""

import numpy as np
import pytest

import tetsim


def icosphere(subdivisions=2):
    """A unit sphere of triangles, outward oriented (an icosahedron, subdivided, projected)."""
    t = (1.0 + 5.0 ** 0.5) / 2.0
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        cache, faces = {}, []
        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            faces += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        f = faces
    return np.array(verts, dtype=np.float64), np.array(f, dtype=np.int64)


def signed_volumes(vertices, tets):
    p = vertices[tets]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0


def test_a_sphere_fills_with_positive_tets_of_about_its_volume():
    vertices, faces = icosphere(3)
    points, tets = tetsim.tetrahedralize(vertices, faces, 0.2)
    assert points.dtype == np.float64 and points.shape[1] == 3
    assert tets.dtype == np.int64 and tets.shape[1] == 4
    assert tets.min() >= 0 and tets.max() < len(points)
    volumes = signed_volumes(points, tets)
    assert (volumes > 0).all()
    # The polyhedron's own volume, by the divergence theorem.
    p = vertices[faces]
    enclosed = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert abs(volumes.sum() - enclosed) / enclosed < 0.05
    # Every vertex lies within a lattice spacing of the sphere's solid.
    assert np.linalg.norm(points, axis=1).max() < 1.0 + 0.2


def test_an_open_sheet_and_a_bad_size_raise_errors_naming_the_argument():
    sheet = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    faces = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    with pytest.raises(tetsim.Error, match="too open"):
        tetsim.tetrahedralize(sheet, faces, 0.1)
    vertices, faces = icosphere(1)
    with pytest.raises(tetsim.Error, match="size"):
        tetsim.tetrahedralize(vertices, faces, -1.0)
    with pytest.raises(tetsim.Error, match="faces"):
        tetsim.tetrahedralize(vertices, faces + 1000, 0.2)
