/* camera.c: the raster convention and field of view, by construction. */
#include <string.h>

#include "core/camera.h"
#include "harness.h"

/* A camera at `position` looking at `lookat`, prepared or not. */
static camera frame(vec3 position, vec3 lookat, double fov, int w, int h)
{
    camera c;
    memset(&c, 0, sizeof c);
    c.position = position, c.lookat = lookat, c.up = v3(0, 1, 0);
    c.fov_degrees = fov, c.width = w, c.height = h;
    return c;
}

static camera make(double fov, int w, int h)
{
    camera c = frame(v3(1, 2, 3), v3(1, 2, -7), fov, w, h);
    rr_error e;
    CHECK(camera_prepare(&c, &e) == 0);
    return c;
}

TEST(camera_center_ray_is_the_view_direction)
{
    camera c = make(40, 64, 48);
    vec3 d = camera_ray_direction(&c, 32, 24);
    CHECK_NEAR(d.x, 0, 1e-15);
    CHECK_NEAR(d.y, 0, 1e-15);
    CHECK_NEAR(d.z, -1, 1e-15);
}

TEST(camera_fov_is_vertical_and_rows_go_down)
{
    camera c = make(60, 200, 100);
    vec3 top = camera_ray_direction(&c, 100, 0), bottom = camera_ray_direction(&c, 100, 100);
    CHECK_NEAR(atan2(top.y, -top.z) * 180 / M_PI, 30, 1e-12); /* raster row 0 is the top */
    CHECK_NEAR(atan2(bottom.y, -bottom.z) * 180 / M_PI, -30, 1e-12);
    vec3 right = camera_ray_direction(&c, 200, 50);
    CHECK_NEAR(right.x / -right.z, 2 * tan(M_PI / 6), 1e-12); /* square pixels: twice as wide */
    CHECK(right.x > 0);                                       /* raster x grows to the right */
    CHECK_NEAR(v3_len(right), 1, 1e-15);
}

TEST(camera_rejects_degenerate_frames)
{
    rr_error e;
    camera same = frame(v3(0, 0, 0), v3(0, 0, 0), 45, 8, 8);
    CHECK(camera_prepare(&same, &e) != 0);
    camera parallel = frame(v3(0, 0, 0), v3(0, 5, 0), 45, 8, 8);
    CHECK(camera_prepare(&parallel, &e) != 0);
    camera wide = frame(v3(0, 0, 0), v3(0, 0, -1), 180, 8, 8);
    CHECK(camera_prepare(&wide, &e) != 0);
    camera huge = frame(v3(0, 0, 0), v3(0, 0, -1), 45, 65536, 65536);
    CHECK(camera_prepare(&huge, &e) != 0); /* more than RR_MAX_PIXELS */
}

/* Regression: a camera at 1e308 was blamed on its up vector (the
 * distance to lookat overflowed and the view direction came out 0). */
TEST(camera_too_far_from_lookat_is_named_as_such)
{
    camera c = {.position = {0, 0, 1e308}, .lookat = {0, 0, -1e308}, .up = {0, 1, 0}, .fov_degrees = 40,
                .width = 4, .height = 4};
    rr_error e;
    CHECK(camera_prepare(&c, &e) == -1 && strstr(e.msg, "too far apart") && !strstr(e.msg, "up"));
}

/* Lengths were taken by squaring: a lookat 1e300 away (finite, but its
 * square is not) was blamed on up, and so was an up of 1e308; a lookat
 * 1e-200 away was called equal to the position. Directions do not depend
 * on the scale of the vectors they come from. */
TEST(camera_frame_does_not_depend_on_the_scale_of_its_vectors)
{
    const double scales[] = {1e-200, 1e300};
    for (int i = 0; i < 2; i++) {
        camera c = frame(v3(0, 0, 0), v3(0, 0, -scales[i]), 40, 4, 4);
        c.up = v3(0, scales[i], 0);
        rr_error e;
        CHECK(camera_prepare(&c, &e) == 0);
        CHECK_NEAR(c.forward.z, -1, 1e-15);
        CHECK_NEAR(c.image_up.y, 1, 1e-15);
        CHECK_NEAR(c.right.x, 1, 1e-15);
    }
    camera big_up = frame(v3(0, 0, 5), v3(0, 0, 0), 40, 4, 4);
    big_up.up = v3(1e308, 1e308, 0);
    rr_error e;
    CHECK(camera_prepare(&big_up, &e) == 0);
    CHECK_NEAR(big_up.image_up.x, sqrt(0.5), 1e-15);
    camera inf = frame(v3(INFINITY, 0, 0), v3(0, 0, 0), 40, 4, 4);
    CHECK(camera_prepare(&inf, &e) == -1 && strstr(e.msg, "must be finite"));
}
