/* test_switching.c - switching distances and coverage against values worked
 * out by hand from the projection, and their defining property: at distance d
 * the error projects to exactly p pixels. */
#include <math.h>

#include "check.h"
#include "switching.h"

static const switching_camera kCamera = {1.0, 1080.0, 1.0471975511965976}; /* 60 degrees */

static void distance_makes_error_p_pixels(void)
{
    const double e = 0.01, s = 2.5;
    double d = switching_distance(e, s, &kCamera);
    /* pixels covered by e*s at distance d */
    double pixels = e * s / (2.0 * d * tan(kCamera.fov_y / 2.0)) * kCamera.viewport_height;
    CHECK(fabs(pixels - kCamera.pixel_error) < 1e-12, "projected error %.17g px", pixels);
    /* by hand: 0.025 * 1080 / (2 * tan(30 deg) * 1) = 27 / 1.1547005 = 23.3826859 */
    CHECK(fabs(d - 23.382685902179844) < 1e-9, "d = %.17g", d);
}

static void distance_scales_linearly(void)
{
    double d1 = switching_distance(0.01, 1.0, &kCamera), d2 = switching_distance(0.02, 1.0, &kCamera);
    double d3 = switching_distance(0.01, 3.0, &kCamera);
    CHECK(fabs(d2 - 2 * d1) < 1e-12 && fabs(d3 - 3 * d1) < 1e-12, "%g %g %g", d1, d2, d3);
    switching_camera coarse = kCamera;
    coarse.pixel_error = 4.0;
    CHECK(fabs(switching_distance(0.01, 1.0, &coarse) - d1 / 4) < 1e-12, "pixel threshold divides");
    CHECK(switching_distance(0.0, 1.0, &kCamera) == 0.0, "error 0 -> distance 0");
}

static void coverage(void)
{
    /* a sphere of radius R at distance R / tan(fov/2) spans the whole viewport height */
    double R = 2.0, d = R / tan(kCamera.fov_y / 2.0);
    CHECK(fabs(switching_coverage(R, d, &kCamera) - 1.0) < 1e-12, "full height");
    CHECK(fabs(switching_coverage(R, 4 * d, &kCamera) - 0.25) < 1e-12, "quarter height");
    CHECK(switching_coverage(R, 0.0, &kCamera) == 1.0, "distance 0 -> 1");
    CHECK(switching_coverage(R, d / 10, &kCamera) == 1.0, "clamped to 1");
    CHECK(fabs(switching_cull_coverage(&kCamera) - 1.0 / 1080.0) < 1e-15, "cull = p / H");
}

int main(void)
{
    RUN(distance_makes_error_p_pixels);
    RUN(distance_scales_linearly);
    RUN(coverage);
    return check_summary();
}
