"""Adsorption sites on the voxel walls and their neighbour graph (Mahler 2001 §4.4: surface element = voxel face).

Every wall face of a pore voxel (the pore voxel's side that touches a solid voxel, or the closed outside of the box)
carries ``s × s`` sites. Face ``f`` is voxel ``site_face[f, :3]`` with face event ``ev = site_face[f, 3]``
(= 2·axis + (normal points to +axis)); its in-plane axes are a = (axis + 1) % 3 and b = (axis + 2) % 3 and site
``(f·s + ia)·s + ib`` covers [ia/s, (ia+1)/s) × [ib/s, (ib+1)/s) of the face.

Neighbour graph, directions k = +a, −a, +b, −b (in the face's own axes):

- ``"face"``: the in-face neighbour, none (-1) across the face's border (a 2×2 face: every site has 2);
- ``"surface"``: across a face border the walk continues on the face that meets it at that voxel edge. Walking from
  face (q, n) in the in-plane direction d: if q + d is solid the edge is concave and the next face is (q, d); else
  if q + d + n is solid the wall is flat and the next face is (q + d, n); else the edge is convex and the next face
  is (q + d + n, −d). Testing the concave case first splits an edge where two solid voxels touch only along it
  into two sheets, so the graph is symmetric and every site has exactly 4 neighbours on any voxel surface.
"""

from __future__ import annotations

import numpy as np

from porepipe._shared.errors import PorepipeError

#: in-face steps of the directions k = 0..3 in (ia, ib)
NEIGH = ((1, 0), (-1, 0), (0, 1), (0, -1))


def wall_sites(codes: np.ndarray, periodic) -> tuple[np.ndarray, np.ndarray]:
    """Wall faces of the pore voxels: ``face_of`` ((n·6,) int64, face id or -1 per voxel and face event
    2·axis + (step > 0)) and ``site_face`` ((m, 4) int64: voxel index and face event per face id).
    """
    pore = codes > 0
    walls = []
    for ax in range(3):
        for up in (0, 1):
            shifted = np.roll(pore, -1 if up else 1, axis=ax)
            wall = pore & ~shifted
            if not periodic[ax]:
                edge = [slice(None)] * 3
                edge[ax] = -1 if up else 0
                wall[tuple(edge)] = pore[tuple(edge)]
            walls.append(wall)
    stack = np.stack(walls, axis=-1)  # (n0, n1, n2, 6)
    face_of = np.full(stack.size, -1, dtype=np.int64)
    flat = np.flatnonzero(stack.reshape(-1))
    face_of[flat] = np.arange(flat.size)
    vox = np.column_stack(np.unravel_index(flat // 6, codes.shape))
    return face_of, np.column_stack([vox, flat % 6]).astype(np.int64)


def _is_pore(pore, periodic, q):
    """Pore test of voxel rows ``q`` (m, 3); outside a closed axis counts as solid, a periodic one wraps."""
    shape = np.array(pore.shape)
    per = np.asarray(periodic, bool)
    q = np.where(per, q % shape, q)
    inside = np.all((q >= 0) & (q < shape), axis=1)
    out = np.zeros(q.shape[0], bool)
    qi = q[inside]
    out[inside] = pore[qi[:, 0], qi[:, 1], qi[:, 2]]
    return out, q


def _face_id(face_of, shape, q, ev):
    return face_of[((q[:, 0] * shape[1] + q[:, 1]) * shape[2] + q[:, 2]) * 6 + ev]


def _next_faces(pore, periodic, face_of, site_face, c, sigma):
    """Face across the border of every face walking along its in-plane axis ``c`` (per face) in direction
    ``sigma`` (±1); returns (face id, edge kind: 0 concave, 1 flat, 2 convex).
    """
    rows = np.arange(site_face.shape[0])
    q, ev = site_face[:, :3], site_face[:, 3]
    n = np.zeros_like(q)
    n[rows, ev >> 1] = np.where(ev & 1, 1, -1)
    d = np.zeros_like(q)
    d[rows, c] = sigma
    pore_d, qd = _is_pore(pore, periodic, q + d)
    pore_dn, qdn = _is_pore(pore, periodic, q + d + n)
    kind = np.where(~pore_d, 0, np.where(~pore_dn, 1, 2))
    vox = np.where((kind == 0)[:, None], q, np.where((kind == 1)[:, None], qd, qdn))
    evn = np.where(kind == 0, 2 * c + (sigma > 0), np.where(kind == 1, ev, 2 * c + (sigma < 0)))
    fid = _face_id(face_of, pore.shape, vox, evn)
    if np.any(fid < 0):
        raise PorepipeError("internal: a wall face has no neighbour face across one of its edges")
    return fid, kind


def _entry_site(site_face, s, f, along, e, g, kind, sigma):
    """Site of face ``g`` at the edge (axis ``e``) that sites of faces ``f`` cross (index ``along`` on the edge).

    Index across the edge on ``g``: concave and convex edges run it along f's normal axis (concave: the edge lies
    on f's normal side of the voxel, convex: on the far side of the next voxel), a flat edge along the walking axis
    (entered from the −sigma side).
    """
    n_up = (site_face[f, 3] & 1) == 1
    flat = 0 if sigma > 0 else s - 1
    across = np.where(
        kind == 0, np.where(n_up, s - 1, 0), np.where(kind == 1, flat, np.where(n_up, 0, s - 1))
    )
    first_is_edge = ((site_face[g, 3] >> 1) + 1) % 3 == e
    ia2 = np.where(first_is_edge, along, across)
    ib2 = np.where(first_is_edge, across, along)
    return (g * s + ia2) * s + ib2


def site_neighbours(codes: np.ndarray, periodic, face_of, site_face, s: int, graph: str) -> np.ndarray:
    """(n_sites, 4) int64 neighbour site per direction k = +a, −a, +b, −b (-1 = none); ``graph`` "face" or
    "surface" (see the module docstring).
    """
    if graph not in ("face", "surface"):
        raise PorepipeError(f"neighbours must be face or surface, got {graph!r}")
    m = site_face.shape[0]
    ia, ib = (x.reshape(-1) for x in np.meshgrid(np.arange(s), np.arange(s), indexing="ij"))
    f = np.repeat(np.arange(m), s * s)
    ia, ib = np.tile(ia, m), np.tile(ib, m)
    out = np.full((m * s * s, 4), -1, dtype=np.int64)
    ax = site_face[:, 3] >> 1
    for k, (da, db) in enumerate(NEIGH):
        ja, jb = ia + da, ib + db
        inside = (ja >= 0) & (ja < s) & (jb >= 0) & (jb < s)
        out[inside, k] = (f[inside] * s + ja[inside]) * s + jb[inside]
        if graph == "face":
            continue
        c = (ax + 1) % 3 if k < 2 else (ax + 2) % 3  # per face: the walking axis
        sigma = da + db
        fid, kind = _next_faces(codes > 0, periodic, face_of, site_face, c, sigma)
        cross = ~inside
        fc = f[cross]
        along = ib[cross] if k < 2 else ia[cross]  # the other in-plane index runs along the edge
        e = 3 - ax - c
        out[cross, k] = _entry_site(site_face, s, fc, along, e[fc], fid[fc], kind[fc], sigma)
    return out
