/* Rigid transforms at time t and their exact inverses (thesis B.2.3). */
#include "animation.h"
#include "harness.h"

static int near3(vec3 a, vec3 b, double tol) { return v3_len(v3_sub(a, b)) <= tol; }

TEST(linear_animation_moves_points_by_velocity_times_time)
{
    animation a;
    animation_init_static(&a);
    a.offset = v3(1, 0, 0);
    a.velocity = v3(0, -2, 0.5);
    xform x = animation_at(&a, 1.5); /* absolute time: displacement v * 1.5 */
    CHECK(near3(xform_point(&x, v3(0, 1, 0)), v3(1, 1 - 3, 0.75), 1e-12));
}

TEST(rotation_is_right_handed_about_axis_through_center)
{
    animation a;
    animation_init_static(&a);
    a.has_rotation = 1;
    a.axis = v3(0, 0, 1);
    a.center = v3(1, 1, 0);
    a.degrees_per_time = 90;
    /* point (2,1,0) is +x of the center; +90 deg about +z takes it to (1,2,0) */
    xform x = animation_at(&a, 1.0);
    CHECK(near3(xform_point(&x, v3(2, 1, 0)), v3(1, 2, 0), 1e-12));
    x = animation_at(&a, 2.0); /* 180 deg */
    CHECK(near3(xform_point(&x, v3(2, 1, 5)), v3(0, 1, 5), 1e-12));
}

TEST(rotation_applies_before_translation)
{
    animation a;
    animation_init_static(&a);
    a.has_rotation = 1;
    a.axis = v3(0, 0, 1);
    a.degrees_per_time = 90;
    a.velocity = v3(10, 0, 0);
    /* rotate (1,0,0) about the origin to (0,1,0), then translate by (10,0,0) */
    xform x = animation_at(&a, 1.0);
    CHECK(near3(xform_point(&x, v3(1, 0, 0)), v3(10, 1, 0), 1e-12));
}

TEST(inverse_transform_is_exact_and_keeps_distances)
{
    animation a;
    animation_init_static(&a);
    a.has_rotation = 1;
    a.axis = v3_normalize(v3(1, 2, 3));
    a.center = v3(-1, 0.5, 2);
    a.degrees_per_time = 73;
    a.velocity = v3(0.3, -0.2, 0.1);
    a.offset = v3(0.1, 0.2, 0.3);
    for (int i = 0; i < 20; i++) {
        double t = -1 + 0.17 * i;
        xform x = animation_at(&a, t);
        vec3 p = v3(sin(i), cos(3 * i), 0.5 * i);
        CHECK(near3(xform_inverse_point(&x, xform_point(&x, p)), p, 1e-12));
        vec3 d = v3_normalize(v3(1, -i, 2));
        CHECK_NEAR(v3_len(xform_inverse_vector(&x, d)), 1.0, 1e-12);
    }
}

TEST(swept_bounds_contain_the_object_at_all_times)
{
    animation a;
    animation_init_static(&a);
    a.has_rotation = 1;
    a.axis = v3_normalize(v3(0.2, 1, 0.1));
    a.center = v3(3, 0, 0);
    a.degrees_per_time = 250; /* fast: many degrees between sampling steps */
    a.velocity = v3(1, 2, 0);
    aabb box = {v3(-1, -0.5, -0.2), v3(1, 0.5, 0.2)};
    aabb swept = animation_swept_bounds(&a, box, 0.0, 1.0);
    int inside = 1;
    for (int i = 0; i <= 20000; i++) {
        xform x = animation_at(&a, i / 20000.0);
        for (int c = 0; c < 8; c++) {
            vec3 p = v3(c & 1 ? 1 : -1, c & 2 ? 0.5 : -0.5, c & 4 ? 0.2 : -0.2);
            vec3 q = xform_point(&x, p);
            inside &= q.x >= swept.lo.x && q.y >= swept.lo.y && q.z >= swept.lo.z &&
                      q.x <= swept.hi.x && q.y <= swept.hi.y && q.z <= swept.hi.z;
        }
    }
    CHECK(inside);
}
