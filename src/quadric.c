/* quadric.c - see quadric.h. */
#include "quadric.h"

void quadric_from_plane(quadric *q, const double n[3], double d, double w)
{
    q->a00 = w * n[0] * n[0];
    q->a11 = w * n[1] * n[1];
    q->a22 = w * n[2] * n[2];
    q->a01 = w * n[0] * n[1];
    q->a02 = w * n[0] * n[2];
    q->a12 = w * n[1] * n[2];
    q->b0 = w * d * n[0];
    q->b1 = w * d * n[1];
    q->b2 = w * d * n[2];
    q->c = w * d * d;
}

void quadric_add(quadric *into, const quadric *q)
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

double quadric_error(const quadric *q, const double p[3])
{
    const double x = p[0], y = p[1], z = p[2];
    double e = q->a00 * x * x + q->a11 * y * y + q->a22 * z * z +
               2.0 * (q->a01 * x * y + q->a02 * x * z + q->a12 * y * z) +
               2.0 * (q->b0 * x + q->b1 * y + q->b2 * z) + q->c;
    return e > 0.0 ? e : 0.0;
}
