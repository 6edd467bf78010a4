"""The faces of the plane graph of a wire and its contact links, and which of them are loops.

The graph's vertices are the nodes and the links' feet inside segments; its edges the pieces
of the segments between them and the links. The faces are traced on a half-edge structure
(edges sorted by angle around each vertex): half-edges ``2e`` and ``2e + 1`` are twins.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .depths import csr_groups, loop_contacts, loop_depths
from .record import LoopStats, _frozen

__all__ = ["faces"]


@njit(cache=True)
def _next_half_edges(org, ang, n_v):
    """Successor of each half-edge around its face (face on the left, bounded faces CCW).

    Half-edges ``2e`` and ``2e + 1`` are twins. Out of each vertex the half-edges are sorted
    by angle (counting sort by vertex, then insertion sort: degrees are small); the successor
    of u -> v is the half-edge out of v just clockwise of v -> u.
    """
    nh = org.shape[0]
    start, order = csr_groups(org, n_v)
    for v in range(n_v):
        for i in range(start[v] + 1, start[v + 1]):
            h = order[i]
            a = ang[h]
            j = i - 1
            while j >= start[v] and ang[order[j]] > a:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = h
    rank = np.empty(nh, dtype=np.int64)
    for i in range(nh):
        rank[order[i]] = i
    nxt = np.empty(nh, dtype=np.int64)
    for h in range(nh):
        t = h ^ 1
        v = org[t]
        s0 = start[v]
        d = start[v + 1] - s0
        nxt[h] = order[s0 + (rank[t] - s0 - 1) % d]
    return nxt


@njit(cache=True)
def _trace_faces(nxt):
    """Label the cycles of the permutation ``nxt`` (one per face); returns labels, count."""
    nh = nxt.shape[0]
    face = np.full(nh, -1, dtype=np.int64)
    nf = 0
    for h in range(nh):
        if face[h] >= 0:
            continue
        g = h
        while face[g] < 0:
            face[g] = nf
            g = nxt[g]
        nf += 1
    return face, nf


@njit(cache=True)
def _face_sums(face, nf, org, dst, vx, vy, is_link, elen):
    """Per face: signed area (about the face's first vertex), wire length, link length, number
    of links, area moments for the centroid."""
    nh = face.shape[0]
    ref = np.full(nf, -1, dtype=np.int64)
    area = np.zeros(nf)
    mx = np.zeros(nf)
    my = np.zeros(nf)
    wire = np.zeros(nf)
    link = np.zeros(nf)
    nlink = np.zeros(nf, dtype=np.int64)
    for h in range(nh):
        f = face[h]
        if ref[f] < 0:
            ref[f] = org[h]
        x0, y0 = vx[ref[f]], vy[ref[f]]
        ax, ay = vx[org[h]] - x0, vy[org[h]] - y0
        bx, by = vx[dst[h]] - x0, vy[dst[h]] - y0
        cr = ax * by - bx * ay
        area[f] += 0.5 * cr
        mx[f] += (ax + bx) * cr / 6.0
        my[f] += (ay + by) * cr / 6.0
        if is_link[h]:
            link[f] += elen[h]
            nlink[f] += 1
        else:
            wire[f] += elen[h]
    cx = np.empty(nf)
    cy = np.empty(nf)
    for f in range(nf):
        x0, y0 = vx[ref[f]], vy[ref[f]]
        if area[f] != 0.0:
            cx[f] = x0 + mx[f] / area[f]
            cy[f] = y0 + my[f] / area[f]
        else:
            cx[f] = x0
            cy[f] = y0
    return area, wire, link, nlink, cx, cy


def _vertices(pos, lj, lt, lo, fx, fy):
    """The nodes, then the feet inside segments (one per distinct (segment, t)). Returns the
    vertex coordinates, the vertex of each foot link, and the segment of each foot."""
    n = pos.shape[0]
    is_foot = lo < 0
    fj, ft = lj[is_foot], lt[is_foot]
    forder = np.lexsort((ft, fj))
    fj_s, ft_s = fj[forder], ft[forder]
    first = np.ones(fj_s.shape[0], dtype=bool)
    first[1:] = (fj_s[1:] != fj_s[:-1]) | (ft_s[1:] != ft_s[:-1])
    uid = np.cumsum(first) - 1
    foot_vertex = np.empty(fj.shape[0], dtype=np.int64)
    foot_vertex[forder] = n + uid
    foot_seg = fj_s[first]
    vx = np.r_[pos[:, 0], fx[is_foot][forder][first]]
    vy = np.r_[pos[:, 1], fy[is_foot][forder][first]]
    return vx, vy, foot_vertex, foot_seg


def _wire_edges(n, foot_seg):
    """Each segment split at its feet, in order of t: (origin, destination, segment) of each
    wire edge."""
    ns = n - 1
    n_feet = foot_seg.shape[0]
    counts = np.bincount(foot_seg, minlength=ns)
    chain_start = np.r_[0, np.cumsum(counts + 1)]  # edges of segment j start here
    n_wire = int(chain_start[-1])
    # vertex sequence along the wire: node j, feet of j, node j+1 (shared between segments)
    seq = np.empty(n_wire + 1, dtype=np.int64)
    node_at = chain_start[:-1]  # index in seq of node j
    seq[node_at] = np.arange(ns)
    seq[-1] = ns
    if n_feet:
        within = np.arange(n_feet) - np.r_[0, np.cumsum(counts)][foot_seg]
        seq[node_at[foot_seg] + 1 + within] = n + np.arange(n_feet)
    return seq[:-1], seq[1:], np.repeat(np.arange(ns), counts + 1)


def _directions(pos, lk, lj, lt, lo, w_seg, n_wire):
    """Direction of every edge: wire edges along their segment (exact data), links from the
    relative vector (a foot link leaves its segment on the side of its node)."""
    is_foot = lo < 0
    seg_dx = np.diff(pos[:, 0])
    seg_dy = np.diff(pos[:, 1])
    dxe = np.r_[seg_dx[w_seg], np.where(lo >= 0, pos[np.maximum(lo, 0), 0] - pos[lk, 0], 0.0)]
    dye = np.r_[seg_dy[w_seg], np.where(lo >= 0, pos[np.maximum(lo, 0), 1] - pos[lk, 1], 0.0)]
    if np.any(is_foot):
        jj, tt, kk = lj[is_foot], lt[is_foot], lk[is_foot]
        rx = (pos[jj, 0] - pos[kk, 0]) + tt * seg_dx[jj]
        ry = (pos[jj, 1] - pos[kk, 1]) + tt * seg_dy[jj]
        # the foot end of the link must leave the segment on the side of the node
        side = np.sign(
            seg_dx[jj] * (pos[kk, 1] - pos[jj, 1]) - seg_dy[jj] * (pos[kk, 0] - pos[jj, 0])
        )
        wrong = np.sign(seg_dx[jj] * (-ry) - seg_dy[jj] * (-rx)) != side
        if np.any(wrong):  # round-off on a link far shorter than the segment: use the normal
            rx = np.where(wrong, side * seg_dy[jj], rx)
            ry = np.where(wrong, -side * seg_dx[jj], ry)
        idx = n_wire + np.flatnonzero(is_foot)
        dxe[idx] = rx
        dye[idx] = ry
    return dxe, dye


def _half_edges(e_org, e_dst, dxe, dye, n_wire):
    """Half-edges 2e (org -> dst) and 2e + 1 (dst -> org): origin, destination, angle, and
    whether each is a link."""
    n_e = e_org.shape[0]
    org = np.empty(2 * n_e, dtype=np.int64)
    dst = np.empty(2 * n_e, dtype=np.int64)
    org[0::2], org[1::2] = e_org, e_dst
    dst[0::2], dst[1::2] = e_dst, e_org
    ang = np.empty(2 * n_e)
    ang[0::2] = np.arctan2(dye, dxe)
    ang[1::2] = np.arctan2(-dye, -dxe)
    is_link = np.zeros(2 * n_e, dtype=bool)
    is_link[2 * n_wire :] = True
    return org, dst, ang, is_link


def _boundaries(ids, face, nf, nxt, org, vx, vy) -> tuple:
    """Boundary polygon of each face in ``ids`` (for drawing)."""
    first_h = np.full(nf, -1, dtype=np.int64)
    first_h[face[::-1]] = np.arange(face.shape[0])[::-1]  # lowest half-edge of each face
    out = []
    for f in ids:
        h0 = first_h[f]
        walk = [h0]
        h = nxt[h0]
        while h != h0:
            walk.append(h)
            h = nxt[h]
        walk = np.array(walk)
        out.append(np.c_[vx[org[walk]], vy[org[walk]]])
    return tuple(out)


def _plane_graph(pos, lk, lj, lt, lo, fx, fy):
    """The half-edge structure of the wire and its links, its faces traced."""
    vx, vy, foot_vertex, foot_seg = _vertices(pos, lj, lt, lo, fx, fy)
    w_org, w_dst, w_seg = _wire_edges(pos.shape[0], foot_seg)
    n_wire = w_org.shape[0]
    l_org = lk
    l_dst = np.where(lo >= 0, lo, 0)
    l_dst[lo < 0] = foot_vertex
    e_org, e_dst = np.r_[w_org, l_org], np.r_[w_dst, l_dst]
    dxe, dye = _directions(pos, lk, lj, lt, lo, w_seg, n_wire)
    org, dst, ang, is_link = _half_edges(e_org, e_dst, dxe, dye, n_wire)
    hlen = np.repeat(np.hypot(vx[e_dst] - vx[e_org], vy[e_dst] - vy[e_org]), 2)
    nxt = _next_half_edges(org, ang, vx.shape[0])
    face, nf = _trace_faces(nxt)
    return vx, vy, org, dst, is_link, hlen, nxt, face, nf, l_org, l_dst


def faces(pos, lk, lj, lt, lo, fx, fy, c, w, n_links, want_boundaries) -> LoopStats:
    """The loops of the plane graph of ``pos`` and its links (:func:`crumple.loops.loops`):
    bounded faces of mean width ``2 A / P >= w``; the narrower ones are slivers."""
    graph = _plane_graph(pos, lk, lj, lt, lo, fx, fy)
    vx, vy, org, dst, is_link, hlen, nxt, face, nf, l_org, l_dst = graph
    # Euler: the wire is a tree (one face) and every link closes one more face. Anything else
    # means the drawing is not plane (edges crossing by round-off): refuse rather than guess.
    if nf != n_links + 1:
        raise RuntimeError(
            f"loops: the wire and its {n_links} contact links trace {nf} faces instead of "
            f"{n_links + 1}; the contact graph is not plane (strands closer than round-off?)"
        )
    area, wire_len, link_len, _, cx, cy = _face_sums(face, nf, org, dst, vx, vy, is_link, hlen)
    bounded = np.ones(nf, dtype=bool)
    bounded[int(np.argmin(area))] = False
    perim_all = wire_len + link_len
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.where(perim_all > 0, 2.0 * area / perim_all, 0.0)
    is_loop = bounded & (width >= w)
    is_sliver = bounded & ~is_loop
    depth, n_contacts = loop_depths(face, nf, nxt, is_link, is_loop, is_sliver, vx, vy, org)
    ids = np.flatnonzero(is_loop)
    ids = ids[np.lexsort((cy[ids], cx[ids], -area[ids]))]
    return LoopStats(
        contact_distance=c,
        min_width=w,
        area=_frozen(area[ids], float),
        perimeter=_frozen(wire_len[ids], float),
        n_contacts=_frozen(n_contacts[ids], np.int64),
        depth=_frozen(depth[ids], np.int64),
        centroid=_frozen(np.c_[cx[ids], cy[ids]], float),
        n_links=n_links,
        n_slivers=int(np.count_nonzero(bounded & ~is_loop)),
        n_loop_contacts=loop_contacts(face, nf, org, is_loop, l_org, l_dst),
        boundaries=_boundaries(ids, face, nf, nxt, org, vx, vy) if want_boundaries else None,
        links=(
            _frozen(np.stack([np.c_[vx[l_org], vy[l_org]], np.c_[vx[l_dst], vy[l_dst]]], 1), float)
            if want_boundaries
            else None
        ),
    )
