/* overlay.h - the geometry of the overlay partition test (DESIGN.md §4 (a)2
 * and (b)2).
 *
 * A subject triangle S is partitioned by the orthogonal projections of
 * witness triangles W onto S's plane. Each piece S ∩ proj(W) is a convex
 * polygon in S, and the distance to the fixed triangle W is convex, so the
 * piece is within d of W when its corners are: overlay_piece returns that
 * largest corner distance. Whether the pieces of several witnesses cover all
 * of S is the caller's closing-up argument (certify.c), which needs to know
 * which witness edges cross S's interior: overlay_edge_enters.
 *
 * Rounding. Work is done relative to S's first corner. "Interior" means the
 * interior of S' = S shrunk towards its centroid by a factor 1 - 1e-9, so
 * that an edge lying on S's border (a shared edge, the usual case) is never
 * taken for one that enters S. Every point of S is within `slack` of S', and
 * slack also absorbs the rounding of the clipped corners: a caller adds it to
 * every distance it accepts (overlay_piece already does). */
#ifndef LODPIPE_OVERLAY_H
#define LODPIPE_OVERLAY_H

#include "geom.h"

typedef struct overlay_subject {
    vec3d origin;   /* S's first corner; everything else is relative to it */
    vec3d p[3];     /* S's corners (relative), counter-clockwise about n */
    vec3d n;        /* S's unit normal */
    vec3d centroid; /* relative; it lies in S' */
    vec3d inner[3]; /* corners of S' (relative) */
    double area;    /* S's area */
    double slack;
} overlay_subject;

/* 0 when S is degenerate (no trustworthy normal): no overlay then. */
int overlay_subject_init(overlay_subject *s, const vec3d p[3]);

typedef enum {
    OVERLAY_UNUSABLE = -1, /* W's projection onto S's plane is (nearly) a segment */
    OVERLAY_EMPTY = 0,     /* the piece has no area worth a witness */
    OVERLAY_PIECE = 1      /* *max_distance = largest corner distance to W + slack */
} overlay_piece_result;

#define OVERLAY_MAX_CORNERS 9 /* room for a triangle clipped by three half-planes (6) */

/* The piece S ∩ proj(W) for a witness W (absolute coordinates, any winding:
 * the projection's own orientation is used). When corners is not NULL and
 * the result is OVERLAY_PIECE, the piece's corners are written there in
 * absolute coordinates (rounded: within slack of the true ones), *corner_count
 * of them, in order around the piece. */
overlay_piece_result overlay_piece(const overlay_subject *s, const vec3d w[3], double *max_distance,
                                   vec3d corners[OVERLAY_MAX_CORNERS], int *corner_count);

/* 1 when the projection of segment [a, b] (absolute coordinates) meets the
 * interior of S'. */
int overlay_edge_enters(const overlay_subject *s, vec3d a, vec3d b);

/* 1 when S's centroid lies in the closed projection of W. */
int overlay_covers_centroid(const overlay_subject *s, const vec3d w[3]);

#endif
