/* intersect.h - a conservative triangle-triangle intersection test for the
 * simplifier's self-intersection guard (DESIGN.md §5).
 *
 * A collapse is refused when one of the faces it creates intersects a nearby
 * face of the mesh. Neighbouring faces always touch along shared corners and
 * edges, which is not a self-intersection, so the test below ignores exactly
 * the part of the two triangles that their common corners span.
 *
 * Promise. Let A and B be the closed triangles with corners a[0..2] and
 * b[0..2] (each a[i] is x, y, z), and S the set of corner positions that
 * occur in both (compared with ==, so -0.0 and +0.0 are the same position).
 * intersect_triangles returns 0 only when, in exact arithmetic on the given
 * doubles, A and B have no common point outside the convex hull of S:
 *
 *   - S empty:             0 means A and B are disjoint;
 *   - S one corner v:      0 means they touch at v only;
 *   - S two corners u, w:  0 means they touch along the segment uw only;
 *   - every corner of A (or of B) in S: 0 always (that triangle lies in the
 *     hull of S; identical triangles give 0).
 *
 * A returned 0 is never wrong: every sign the test relies on is the sign of
 * an orientation determinant whose computed value exceeds a rigorous bound on
 * its rounding error (a little more than twice Shewchuk's first-stage bounds,
 * plus an absolute 1e-300 for underflow). When a sign is within that bound
 * of zero the test does not guess: it tries the next sound argument (another
 * plane, a 2D projection) and returns 1 when none settles the question.
 *
 * When 1 is returned. Always when the triangles really share a point outside
 * the hull of S (touching counts: a corner on the other's face or edge, an
 * edge crossing an edge, coplanar overlap, one triangle folded onto its
 * neighbour across their shared edge). Also, conservatively, when:
 *   - the configuration is within rounding of touching (a sign could not be
 *     trusted and no other argument separates the triangles);
 *   - a triangle is degenerate (zero area: collinear or repeated corners) and
 *     the test cannot separate it from the other one, e.g. a degenerate
 *     triangle whose edge meets the other triangle only at a shared corner
 *     after passing through it;
 *   - any coordinate is not finite.
 * For well-shaped triangles whose coordinates' orientation determinants are
 * exactly representable (e.g. small integers) the answer is exact.
 *
 * Cost: a finiteness and a box test and at most four signed volumes for the
 * common cases (disjoint, or neighbours that are not coplanar); coplanar
 * neighbours in a flat region are separated with 2D orientations in a
 * coordinate projection, which is exact on the input (it only drops a
 * coordinate).
 *
 * Pure, no allocation, thread-safe. */
#ifndef LODPIPE_INTERSECT_H
#define LODPIPE_INTERSECT_H

/* 1 when closed triangles a and b (may) share a point outside the hull of
 * their common corners, 0 when they certainly do not (see above). */
int intersect_triangles(const double a[3][3], const double b[3][3]);

/* 1 when every coordinate of t is finite: x - x is 0 for a finite x and NaN
 * for an infinite or NaN one, and a NaN survives the sum. */
static inline int intersect_finite(const double t[3][3])
{
    double z = 0.0;
    for (int i = 0; i < 3; i++) z += (t[i][0] - t[i][0]) + (t[i][1] - t[i][1]) + (t[i][2] - t[i][2]);
    return z == 0.0;
}

/* intersect_triangles(a, b) for a caller that has already found both
 * triangles finite (intersect_finite) and their closed bounding boxes
 * overlapping: the same answer, without repeating those two tests (when a
 * triangle is tested against many, they are most of the cost). */
int intersect_triangles_near(const double a[3][3], const double b[3][3]);

#endif
