/* switching.c - see switching.h. */
#include "switching.h"

#include <math.h>

double switching_distance(double error, double scale, const switching_camera *camera)
{
    return error * scale * camera->viewport_height / (2.0 * tan(camera->fov_y / 2.0) * camera->pixel_error);
}

double switching_coverage(double radius, double distance, const switching_camera *camera)
{
    if (!(distance > 0.0)) return 1.0;
    double c = radius / (distance * tan(camera->fov_y / 2.0));
    return c > 1.0 ? 1.0 : (c < 0.0 ? 0.0 : c);
}

double switching_cull_coverage(const switching_camera *camera)
{
    return camera->pixel_error / camera->viewport_height;
}
