"""Voronoi seeds mirrored across the case's cuts, so that a notch given as
a cut is a plane of cell faces (issue 30).

A cut breaks the springs whose cells' centroids lie either side of its
plane, at spring points inside its ``within`` box (model/springs.py).  On
random Voronoi cells the faces those springs sit on zig-zag by about ±30°
about the plane, and the two sides of the notch ride over each other when
sheared (cases/kalthoff_winkler.yaml measured an opening of 0.55 × the
slip).  Seeds mirrored across a plane give faces on it: a point of the
plane is as far from a seed as from its mirror, so within a band of seeds
that is symmetric about the plane every point of the plane lies on a cell
face (the Voronoi diagram of a point set symmetric about a plane is
symmetric, and the plane holds no cell interior).  It is the mirror-node
placement that gives irregular lattices plane boundaries (Yip, Mohle and
Bolander 2005, Comput.-Aided Civ. Inf. 20; mesh/voronoi.py mirrors the
seeds across the box's sides the same way), applied to the cut's plane.

For each cut with ``planar`` (docs/case_file.md, cuts), the seeds within
``band`` × size of its plane whose foot on the plane lies within the cut's
``within`` box are replaced: those on the side the normal points to are
kept (moved off the plane to at least half the minimum spacing), each
with its mirror; those on the other side are dropped, and so is any other
seed closer to a mirror than the minimum spacing.  Mirrors outside the
seeds' box are dropped with their originals' symmetry (only where the band
meets the box's sides).  The count of seeds changes by a few per cent of
the band's.
"""
from __future__ import annotations

import numpy as np

__all__ = ["mirror_across_cuts", "BAND"]

#: half-width of the band of mirrored seeds, in cell sizes: the faces on the
#: plane are those of a seed and its mirror, which are neighbours when no
#: other seed is nearer the plane; one cell each side covers the plane
BAND = 2.0


def mirror_across_cuts(seeds, cuts, size, min_spacing, box):
    """The seeds (N, 3) with each planar cut's band made symmetric about its
    plane (module docstring).  ``cuts``: items with point, normal, within
    and planar (the case's ``cuts``; those with ``planar`` false are
    skipped); ``box`` [[lo], [hi]]: the seeds' box (mirrors outside it are
    dropped).  Returns a new (M, 3) array; the same seeds if no cut."""
    from scipy.spatial import cKDTree
    pts = seeds = np.asarray(seeds, dtype=np.float64)
    lo, hi = np.asarray(box, dtype=np.float64)
    w = BAND * size
    r = max(float(min_spacing), 0.2) * size
    for cut in cuts or ():
        if not cut.planar:
            continue                   # a cut that keeps the cells of its seed
        p = np.asarray(cut.point, dtype=np.float64)
        n = np.asarray(cut.normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        within = np.asarray(cut.within, dtype=np.float64)
        d = (pts - p) @ n
        foot = pts - d[:, None] * n
        # the seeds over the patch alone: beyond its edge (a notch tip) the
        # cells stay random, so that a crack growing from the tip is as
        # tortuous as the fracture calibration assumed (docs/calibration.md:
        # a band widened by two cells made the ligament of the calibration's
        # notched specimen planar and its dissipation 0.60-0.71 of G_f)
        inside = np.all((foot >= within[0]) & (foot <= within[1]), axis=1)
        band = inside & (np.abs(d) < w)
        if not np.any(band):
            continue
        keep = band & (d >= 0)
        depth = np.maximum(d[keep], 0.5 * r)                # off the plane: no sliver cells
        kept = pts[keep] + (depth - d[keep])[:, None] * n
        mirror = kept - 2.0 * depth[:, None] * n
        ok = np.all((mirror > lo) & (mirror < hi) & (kept > lo) & (kept < hi), axis=1)
        kept, mirror = kept[ok], mirror[ok]
        rest = pts[~band]
        if len(rest) and len(mirror):
            near = cKDTree(np.vstack([kept, mirror])).query(rest, k=1,
                                                             distance_upper_bound=r)[0]
            rest = rest[near >= r]
        pts = np.vstack([rest, kept, mirror])
    if pts is not seeds:
        # cells close in space close in memory again (mesh/voronoi.py)
        from .voronoi import _morton_order
        pts = pts[_morton_order(pts, lo, size)]
    return pts
