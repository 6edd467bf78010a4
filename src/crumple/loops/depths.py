"""How deep each loop lies (how many loops enclose it), and where loops touch loops.

Pure array code on the faces of :mod:`crumple.loops.faces` (half-edge ``h``, its twin
``h ^ 1``, ``face[h]`` the face on its left, ``nxt[h]`` its successor around that face).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["loop_contacts", "loop_depths"]


@njit(cache=True)
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True)
def csr_groups(keys, n_groups):
    """Items grouped by key (a counting sort), CSR: the items of group g, in their order, are
    ``members[start[g]:start[g + 1]]``; ``keys`` are ints in [0, n_groups)."""
    n = keys.shape[0]
    start = np.zeros(n_groups + 1, dtype=np.int64)
    for h in range(n):
        start[keys[h] + 1] += 1
    for g in range(n_groups):
        start[g + 1] += start[g]
    members = np.empty(n, dtype=np.int64)
    fill = start[:n_groups].copy()
    for h in range(n):
        members[fill[keys[h]]] = h
        fill[keys[h]] += 1
    return start, members


@njit(cache=True)
def _contact_runs(face, nf, is_link, is_sliver):
    """Contact runs: slivers joined across links. ``root[f]`` names f's run; the slivers of
    run r are ``rmem[rcnt[r]:rcnt[r + 1]]``."""
    nh = face.shape[0]
    par = np.arange(nf)
    for h in range(0, nh, 2):
        if is_link[h]:
            a, b = face[h], face[h + 1]
            if is_sliver[a] and is_sliver[b]:
                ra, rb = _find(par, a), _find(par, b)
                if ra != rb:
                    par[ra] = rb
    root = np.empty(nf, dtype=np.int64)
    for f in range(nf):
        root[f] = _find(par, f)
    rcnt = np.zeros(nf + 1, dtype=np.int64)
    for f in range(nf):
        if is_sliver[f]:
            rcnt[root[f] + 1] += 1
    for f in range(nf):
        rcnt[f + 1] += rcnt[f]
    rmem = np.empty(rcnt[nf], dtype=np.int64)
    rfill = rcnt[:nf].copy()
    for f in range(nf):
        if is_sliver[f]:
            rmem[rfill[root[f]]] = f
            rfill[root[f]] += 1
    return root, rcnt, rmem


@njit(cache=True)
def _contacts_per_loop(face, nf, cnt, fh, is_link, is_loop, is_sliver, root):
    """Contacts on each loop's boundary: a link next to a sliver belongs to that sliver's run,
    any other link is a contact of its own."""
    n_contacts = np.zeros(nf, dtype=np.int64)
    ids = np.empty(face.shape[0], dtype=np.int64)
    for m in range(nf):
        if not is_loop[m]:
            continue
        ni = 0
        for q in range(cnt[m], cnt[m + 1]):
            h = fh[q]
            if is_link[h]:
                g = face[h ^ 1]
                ids[ni] = root[g] if is_sliver[g] else nf + (h >> 1)
                ni += 1
        if ni:
            srt = np.sort(ids[:ni])
            n_contacts[m] = 1
            for z in range(1, ni):
                if srt[z] != srt[z - 1]:
                    n_contacts[m] += 1
    return n_contacts


@njit(cache=True)
def _shadow(m, face, cnt, fh, is_link, is_sliver, root, rcnt, rmem, in_s, members):
    """S(M): loop m and the contact runs across its links; marks ``in_s`` and fills
    ``members``; returns their number."""
    nm = 0
    in_s[m] = m
    members[nm] = m
    nm += 1
    for q in range(cnt[m], cnt[m + 1]):
        h = fh[q]
        if is_link[h]:
            g = face[h ^ 1]
            if is_sliver[g] and in_s[g] != m:
                r = root[g]
                for z in range(rcnt[r], rcnt[r + 1]):
                    in_s[rmem[z]] = m
                    members[nm] = rmem[z]
                    nm += 1
    return nm


@njit(cache=True)
def _boundary_cycles(m, nm, members, face, nxt, cnt, fh, in_s, seen_h, vx, vy, org, cyc):
    """The boundary cycles of S(m), S on the left: their half-edges (``cyc_h``), where each
    starts (``cyc_start``) and its signed area (``cyc_area``). Returns their number."""
    cyc_start, cyc_area, cyc_h = cyc
    nc = 0
    k = 0
    for i in range(nm):
        f = members[i]
        for q in range(cnt[f], cnt[f + 1]):
            h0 = fh[q]
            if in_s[face[h0 ^ 1]] == m or seen_h[h0] == m:
                continue
            cyc_start[nc] = k
            x0, y0 = vx[org[h0]], vy[org[h0]]
            area = 0.0
            h = h0
            while True:
                seen_h[h] = m
                cyc_h[k] = h
                k += 1
                ax, ay = vx[org[h]] - x0, vy[org[h]] - y0
                bx, by = vx[org[h ^ 1]] - x0, vy[org[h ^ 1]] - y0
                area += 0.5 * (ax * by - bx * ay)
                g = nxt[h]
                while in_s[face[g ^ 1]] == m:
                    g = nxt[g ^ 1]
                h = g
                if h == h0:
                    break
            cyc_area[nc] = area
            nc += 1
    cyc_start[nc] = k
    return nc


@njit(cache=True)
def _flood_holes(m, nc, cyc, face, cnt, fh, is_loop, in_s, flood, depth, queue):
    """Every face reached from a hole of S(m) (a cycle other than the outer one, of largest
    area) without entering S(m) is enclosed by m: its depth goes up by one if it is a loop."""
    cyc_start, cyc_area, cyc_h = cyc
    outer = 0
    for c in range(1, nc):
        if cyc_area[c] > cyc_area[outer]:
            outer = c
    qn = 0
    for c in range(nc):
        if c == outer:
            continue
        for z in range(cyc_start[c], cyc_start[c + 1]):
            g = face[cyc_h[z] ^ 1]
            if flood[g] != m and in_s[g] != m:
                flood[g] = m
                queue[qn] = g
                qn += 1
    qi = 0
    while qi < qn:
        f = queue[qi]
        qi += 1
        if is_loop[f]:
            depth[f] += 1
        for q in range(cnt[f], cnt[f + 1]):
            g = face[fh[q] ^ 1]
            if flood[g] != m and in_s[g] != m:
                flood[g] = m
                queue[qn] = g
                qn += 1


@njit(cache=True)
def loop_depths(face, nf, nxt, is_link, is_loop, is_sliver, vx, vy, org):
    """Number of loops enclosing each face, and the number of contacts of each loop.

    A loop M encloses a face F when F lies in a bounded component of the plane minus the
    closure of S(M) = M together with the contact runs on its boundary (slivers joined to M
    across one of its contact links, and the slivers joined to those across links: a run of
    touching segments is one contact, a point of M's boundary). The boundary of S(M) is traced
    as cycles keeping S(M) on the left; the cycle of largest signed area is the outer one, every
    other is a hole, and the faces reached from a hole without entering S(M) are enclosed.
    Cost: O(E) for the tracing plus the total size of the holes (the sum of the depths).
    """
    nh = face.shape[0]
    cnt, fh = csr_groups(face, nf)
    root, rcnt, rmem = _contact_runs(face, nf, is_link, is_sliver)
    n_contacts = _contacts_per_loop(face, nf, cnt, fh, is_link, is_loop, is_sliver, root)
    in_s = np.full(nf, -1, dtype=np.int64)
    seen_h = np.full(nh, -1, dtype=np.int64)
    flood = np.full(nf, -1, dtype=np.int64)
    depth = np.zeros(nf, dtype=np.int64)
    members = np.empty(nf, dtype=np.int64)
    cyc = (np.empty(nh + 1, dtype=np.int64), np.empty(nh + 1), np.empty(nh, dtype=np.int64))
    queue = np.empty(nf, dtype=np.int64)
    for m in range(nf):
        if not is_loop[m]:
            continue
        nm = _shadow(m, face, cnt, fh, is_link, is_sliver, root, rcnt, rmem, in_s, members)
        nc = _boundary_cycles(m, nm, members, face, nxt, cnt, fh, in_s, seen_h, vx, vy, org, cyc)
        if nc >= 2:
            _flood_holes(m, nc, cyc, face, cnt, fh, is_loop, in_s, flood, depth, queue)
    return depth, n_contacts


def loop_contacts(face, nf, org, is_loop, a, b) -> int:
    """Number of links ``a[i] - b[i]`` at which two loops touch (``LoopStats.n_loop_contacts``).

    The loops around a vertex are the faces of its outgoing half-edges. A link counts when some
    loop around ``a`` is not around ``b`` and some loop around ``b`` is not around ``a``. O(E).
    """
    n_l = a.shape[0]
    on_loop = is_loop[face]
    if n_l == 0 or not on_loop.any():
        return 0
    pairs = np.unique(org[on_loop] * nf + face[on_loop])  # (vertex, loop), sorted by vertex
    v_of, f_of = pairs // nf, pairs % nf
    ends = np.r_[a, b]
    lo = np.searchsorted(v_of, ends, side="left")
    cnt = np.searchsorted(v_of, ends, side="right") - lo
    which = np.repeat(np.arange(2 * n_l), cnt)  # one row per (link end, loop around it)
    offset = np.arange(which.shape[0]) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    loop = f_of[lo[which] + offset]
    link = which % n_l
    side = np.where(which < n_l, 1, 2)  # bit 1: around a; bit 2: around b
    key = link * nf + loop
    order = np.argsort(key, kind="stable")
    key, side = key[order], side[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    mask = np.bitwise_or.reduceat(side, start) if start.shape[0] else side
    grp_link = key[start] // nf
    a_only = np.zeros(n_l, dtype=bool)
    b_only = np.zeros(n_l, dtype=bool)
    a_only[grp_link[mask == 1]] = True
    b_only[grp_link[mask == 2]] = True
    return int(np.count_nonzero(a_only & b_only))
