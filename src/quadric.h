/* quadric.h - error quadrics that ORDER collapses (Garland & Heckbert).
 *
 * A quadric sums squared distances to a set of weighted planes. lodpipe uses
 * it only as a cost to decide which collapse to try first; the promise is
 * kept by the certificate (certify.h), never by this number. Positions are
 * taken relative to an origin the caller chooses (the mesh's bbox centre), so
 * a model far from the origin does not lose precision. */
#ifndef LODPIPE_QUADRIC_H
#define LODPIPE_QUADRIC_H

typedef struct quadric {
    double a00, a11, a22, a01, a02, a12; /* symmetric A = sum w n n^T */
    double b0, b1, b2;                   /* b = sum w d n */
    double c;                            /* sum w d^2 */
} quadric;

/* The quadric of the plane n . x + d = 0 (n unit length) with weight w. */
void quadric_from_plane(quadric *q, const double n[3], double d, double w);

/* quadric_add and quadric_error are inline: the simplifier prices every edge
 * around a vertex each time one of its neighbours changes, a sum and an
 * evaluation per edge, and the calls were a third of that. */
static inline void quadric_add(quadric *into, const quadric *q)
{
    into->a00 += q->a00;
    into->a11 += q->a11;
    into->a22 += q->a22;
    into->a01 += q->a01;
    into->a02 += q->a02;
    into->a12 += q->a12;
    into->b0 += q->b0;
    into->b1 += q->b1;
    into->b2 += q->b2;
    into->c += q->c;
}

/* Weighted sum of squared distances of p to the planes (>= 0). */
static inline double quadric_error(const quadric *q, const double p[3])
{
    const double x = p[0], y = p[1], z = p[2];
    double e = q->a00 * x * x + q->a11 * y * y + q->a22 * z * z +
               2.0 * (q->a01 * x * y + q->a02 * x * z + q->a12 * y * z) +
               2.0 * (q->b0 * x + q->b1 * y + q->b2 * z) + q->c;
    return e > 0.0 ? e : 0.0;
}
/* The point on segment [a, b] with the smallest error, in *out. */
void quadric_segment_minimizer(const quadric *q, const double a[3], const double b[3], double out[3]);
/* The point with the smallest error (A x = -b) in *out, when A is well
 * conditioned: returns 1, else 0 and leaves *out alone (a flat or a
 * cylindrical neighbourhood has a line or plane of minimizers). */
int quadric_minimizer(const quadric *q, double out[3]);

#endif
