/* overlay.c - pieces S ∩ proj(W) and edge crossings; see overlay.h. */
#include "overlay.h"

#include <float.h>
#include <math.h>
#include <stddef.h>

#define OVERLAY_SHRINK 1e-9       /* S' = centroid + (1 - OVERLAY_SHRINK) (S - centroid) */
#define OVERLAY_MIN_AREA 1e-14    /* pieces smaller than this fraction of S count as empty */
#define OVERLAY_MIN_FACING 1e-9   /* |cos| between W and S below which proj(W) is a segment */

int overlay_subject_init(overlay_subject *s, const vec3d p[3])
{
    s->origin = p[0];
    for (int k = 0; k < 3; ++k) s->p[k] = geom_sub(p[k], s->origin);
    if (!geom_triangle_unit_normal(&s->p[0], &s->p[1], &s->p[2], &s->n)) return 0;
    vec3d cross = geom_triangle_normal(&s->p[0], &s->p[1], &s->p[2]);
    s->area = 0.5 * geom_length(cross);
    s->centroid = geom_scale(geom_add(s->p[0], geom_add(s->p[1], s->p[2])), 1.0 / 3.0);
    double reach = 0.0, extent = geom_max_abs_component(s->origin);
    for (int k = 0; k < 3; ++k) {
        s->inner[k] = geom_add_scaled(s->centroid, geom_sub(s->p[k], s->centroid), 1.0 - OVERLAY_SHRINK);
        reach = geom_fmax(reach, geom_distance(s->p[k], s->centroid));
        extent = geom_fmax(extent, geom_max_abs_component(s->p[k]));
    }
    /* every point of S is within OVERLAY_SHRINK * reach of S'; the rest is
     * rounding of the relative coordinates and of the clipped corners */
    s->slack = OVERLAY_SHRINK * reach + 64.0 * DBL_EPSILON * extent;
    return 1;
}

/* W relative to S, wound counter-clockwise about S's normal; 0 when its
 * projection is (nearly) a segment. */
static int projected_witness(const overlay_subject *s, const vec3d w[3], vec3d out[3])
{
    for (int k = 0; k < 3; ++k) out[k] = geom_sub(w[k], s->origin);
    vec3d cross = geom_triangle_normal(&out[0], &out[1], &out[2]);
    double along = geom_dot(cross, s->n), length = geom_length(cross);
    if (along < -OVERLAY_MIN_FACING * length) {
        vec3d t = out[1];
        out[1] = out[2];
        out[2] = t;
    } else if (!(along > OVERLAY_MIN_FACING * length)) {
        return 0;
    }
    return 1;
}

/* Keeps the part of poly on the inner side of the plane through a with
 * in-plane normal m (points x with m . (x - a) >= 0). */
static int clip(const vec3d *poly, int count, vec3d a, vec3d m, vec3d *out)
{
    int n = 0;
    for (int i = 0; i < count; ++i) {
        vec3d prev = poly[(i + count - 1) % count], cur = poly[i];
        double dp = geom_dot(m, geom_sub(prev, a)), dc = geom_dot(m, geom_sub(cur, a));
        if ((dc >= 0.0) != (dp >= 0.0)) out[n++] = geom_lerp(prev, cur, dp / (dp - dc));
        if (dc >= 0.0) out[n++] = cur;
    }
    return n;
}

overlay_piece_result overlay_piece(const overlay_subject *s, const vec3d w[3], double *max_distance,
                                   vec3d corners[OVERLAY_MAX_CORNERS], int *corner_count)
{
    vec3d wr[3];
    if (!projected_witness(s, w, wr)) return OVERLAY_UNUSABLE;
    vec3d buffer[2][OVERLAY_MAX_CORNERS];
    int count = 3;
    for (int k = 0; k < 3; ++k) buffer[0][k] = s->p[k];
    double extent = 0.0;
    for (int k = 0; k < 3 && count >= 3; ++k) {
        vec3d a = wr[k], b = wr[(k + 1) % 3];
        extent = geom_fmax(extent, geom_max_abs_component(a));
        count = clip(buffer[k & 1], count, a, geom_cross(s->n, geom_sub(b, a)), buffer[(k + 1) & 1]);
    }
    if (count < 3) return OVERLAY_EMPTY;
    const vec3d *piece = buffer[1]; /* after three clips the result is in buffer[3 & 1] */
    double twice_area = 0.0;
    for (int i = 1; i + 1 < count; ++i)
        twice_area += geom_dot(s->n, geom_triangle_normal(&piece[0], &piece[i], &piece[i + 1]));
    if (!(0.5 * twice_area > OVERLAY_MIN_AREA * s->area)) return OVERLAY_EMPTY;
    double worst = 0.0;
    for (int i = 0; i < count; ++i) {
        double d2 = geom_point_triangle_distance2(&piece[i], &wr[0], &wr[1], &wr[2], NULL);
        if (!(d2 >= worst)) {
            if (d2 != d2) worst = INFINITY; /* NaN: never accepted */
            continue;
        }
        worst = d2;
    }
    *max_distance = sqrt(worst) + s->slack + 64.0 * DBL_EPSILON * extent;
    if (corners) {
        for (int i = 0; i < count; ++i) corners[i] = geom_add(piece[i], s->origin);
        *corner_count = count;
    }
    return OVERLAY_PIECE;
}

int overlay_edge_enters(const overlay_subject *s, vec3d a, vec3d b)
{
    a = geom_sub(a, s->origin);
    b = geom_sub(b, s->origin);
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < 3; ++k) {
        vec3d q = s->inner[k], m = geom_cross(s->n, geom_sub(s->inner[(k + 1) % 3], q));
        double da = geom_dot(m, geom_sub(a, q)), db = geom_dot(m, geom_sub(b, q));
        if (da != da || db != db) return 1; /* NaN: say yes, the caller then demands more */
        if (!(da > 0.0) && !(db > 0.0)) return 0;
        if (da < 0.0) lo = geom_fmax(lo, da / (da - db));
        else if (db < 0.0) hi = geom_fmin(hi, da / (da - db));
    }
    return lo < hi;
}

int overlay_covers_centroid(const overlay_subject *s, const vec3d w[3])
{
    vec3d wr[3];
    if (!projected_witness(s, w, wr)) return 0;
    for (int k = 0; k < 3; ++k) {
        vec3d m = geom_cross(s->n, geom_sub(wr[(k + 1) % 3], wr[k]));
        if (!(geom_dot(m, geom_sub(s->centroid, wr[k])) >= 0.0)) return 0;
    }
    return 1;
}
