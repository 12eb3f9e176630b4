/* switching.h - when a level may replace a finer one on screen (DESIGN.md §8).
 *
 * A level whose certified object-space error is e, on a node that stretches
 * its mesh into the world by at most s (scene_mesh_stretch: the largest
 * singular value of the world transform, or of a skinned node's joints), seen
 * by a camera with vertical field
 * of view fov_y on a viewport H pixels high, differs from the original by at
 * most p pixels on screen beyond the distance
 *
 *     d = e * s * H / (2 * tan(fov_y / 2) * p)
 *
 * (a point displaced by e*s at distance d moves by e*s / (2 d tan(fov_y/2))
 * of the viewport height). Screen coverage is the fraction of the viewport
 * height that the node's world bounding sphere (radius R) spans at distance d:
 * c = R / (d * tan(fov_y / 2)), clamped to [0, 1]; it is what MSFT_lod's
 * extras.MSFT_screencoverage lists. */
#ifndef LODPIPE_SWITCHING_H
#define LODPIPE_SWITCHING_H

typedef struct switching_camera {
    double pixel_error;     /* p, pixels (> 0) */
    double viewport_height; /* H, pixels (> 0) */
    double fov_y;           /* radians, in (0, pi) */
} switching_camera;

/* d for error e (mesh units) on a node of world scale s. */
double switching_distance(double error, double scale, const switching_camera *camera);

/* c for a world bounding-sphere radius at a distance; 1 at distance 0. */
double switching_coverage(double radius, double distance, const switching_camera *camera);

/* The coverage below which the whole node is smaller than p pixels: p / H. */
double switching_cull_coverage(const switching_camera *camera);

#endif
