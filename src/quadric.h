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
void quadric_add(quadric *into, const quadric *q);
/* Weighted sum of squared distances of p to the planes (>= 0). */
double quadric_error(const quadric *q, const double p[3]);
/* The point on segment [a, b] with the smallest error, in *out. */
void quadric_segment_minimizer(const quadric *q, const double a[3], const double b[3], double out[3]);
/* The point with the smallest error (A x = -b) in *out, when A is well
 * conditioned: returns 1, else 0 and leaves *out alone (a flat or a
 * cylindrical neighbourhood has a line or plane of minimizers). */
int quadric_minimizer(const quadric *q, double out[3]);

#endif
