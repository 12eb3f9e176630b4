/* quadric.c - see quadric.h. */
#include "quadric.h"

#include <math.h>

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

void quadric_segment_minimizer(const quadric *q, const double a[3], const double b[3], double out[3])
{
    /* e(a + t d) = e(a) + 2 t g + t^2 h, g = d . (A a + b), h = d . A d */
    const double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double ad[3] = {q->a00 * d[0] + q->a01 * d[1] + q->a02 * d[2], q->a01 * d[0] + q->a11 * d[1] + q->a12 * d[2],
                          q->a02 * d[0] + q->a12 * d[1] + q->a22 * d[2]};
    const double h = d[0] * ad[0] + d[1] * ad[1] + d[2] * ad[2];
    const double g = a[0] * ad[0] + a[1] * ad[1] + a[2] * ad[2] + q->b0 * d[0] + q->b1 * d[1] + q->b2 * d[2];
    double t = h > 0.0 ? -g / h : 0.5;
    if (!(t > 0.0)) t = 0.0;
    if (t > 1.0) t = 1.0;
    for (int k = 0; k < 3; ++k) out[k] = a[k] + t * d[k];
}

int quadric_minimizer(const quadric *q, double out[3])
{
    /* Cramer's rule on the symmetric 3x3 system; the determinant is compared
     * with the cube of the matrix's scale so the test does not depend on units */
    const double a = q->a00, b = q->a01, c = q->a02, d = q->a11, e = q->a12, f = q->a22;
    const double c00 = d * f - e * e, c01 = c * e - b * f, c02 = b * e - c * d;
    const double det = a * c00 + b * c01 + c * c02;
    const double scale = fabs(a) + fabs(d) + fabs(f);
    if (!(scale > 0.0) || !(fabs(det) > 1e-6 * scale * scale * scale)) return 0;
    const double c11 = a * f - c * c, c12 = b * c - a * e, c22 = a * d - b * b;
    const double r0 = -q->b0, r1 = -q->b1, r2 = -q->b2;
    const double x = (c00 * r0 + c01 * r1 + c02 * r2) / det;
    const double y = (c01 * r0 + c11 * r1 + c12 * r2) / det;
    const double z = (c02 * r0 + c12 * r1 + c22 * r2) / det;
    if (!isfinite(x) || !isfinite(y) || !isfinite(z)) return 0;
    out[0] = x;
    out[1] = y;
    out[2] = z;
    return 1;
}
