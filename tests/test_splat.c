/* Ray/ellipse intersection and kernel weight (thesis eq. 4.2). Expected
 * values are worked out by hand in the comments. */
#include "harness.h"
#include "surfels/splat.h"

static splat_geom make(vec3 c, vec3 u, vec3 v)
{
    splat_geom g;
    CHECK(splat_geom_init(&g, c, u, v) == 0);
    return g;
}

TEST(splat_hit_at_center_gives_plane_distance)
{
    /* splat in z = -3 facing the origin; ray along -z hits at t = 3, r = 0 */
    splat_geom g = make(v3(0, 0, -3), v3(1, 0, 0), v3(0, 1, 0));
    float o[3] = {0, 0, 0}, d[3] = {0, 0, -1}, t, r2;
    CHECK(splat_intersect(&g, o, d, 0, INFINITY, &t, &r2));
    CHECK_NEAR(t, 3.0, 1e-6);
    CHECK_NEAR(r2, 0.0, 1e-12);
}

TEST(splat_elliptical_axes_scale_the_kernel_radius)
{
    /* u has length 2, v length 0.5: the point (1.8, 0) is a = 0.9 -> r2 = 0.81;
       (0, 0.4) is b = 0.8 -> r2 = 0.64; (0, 0.6) is b = 1.2 -> outside */
    splat_geom g = make(v3(0, 0, -1), v3(2, 0, 0), v3(0, 0.5, 0));
    float d[3] = {0, 0, -1}, t, r2;
    float o1[3] = {1.8f, 0, 0}, o2[3] = {0, 0.4f, 0}, o3[3] = {0, 0.6f, 0};
    CHECK(splat_intersect(&g, o1, d, 0, INFINITY, &t, &r2));
    CHECK_NEAR(r2, 0.81, 1e-5);
    CHECK(splat_intersect(&g, o2, d, 0, INFINITY, &t, &r2));
    CHECK_NEAR(r2, 0.64, 1e-5);
    CHECK(!splat_intersect(&g, o3, d, 0, INFINITY, &t, &r2));
}

TEST(splat_non_orthogonal_axes_use_the_dual_basis)
{
    /* u = (1,0,0), v = (1,1,0): the point c + 0.3u + 0.4v = (0.7, 0.4) has
       a = 0.3, b = 0.4, r2 = 0.25 */
    splat_geom g = make(v3(0, 0, 0), v3(1, 0, 0), v3(1, 1, 0));
    float o[3] = {0.7f, 0.4f, 5}, d[3] = {0, 0, -1}, t, r2;
    CHECK(splat_intersect(&g, o, d, 0, INFINITY, &t, &r2));
    CHECK_NEAR(r2, 0.25, 1e-5);
    CHECK_NEAR(t, 5.0, 1e-5);
}

TEST(splat_oblique_ray_distance_is_along_the_ray)
{
    /* ray from origin towards (1, 0, -1)/sqrt2 meets z = -1 at t = sqrt 2 */
    splat_geom g = make(v3(1, 0, -1), v3(0.5, 0, 0), v3(0, 0.5, 0));
    float s = (float)M_SQRT1_2, o[3] = {0, 0, 0}, d[3] = {s, 0, -s}, t, r2;
    CHECK(splat_intersect(&g, o, d, 0, INFINITY, &t, &r2));
    CHECK_NEAR(t, M_SQRT2, 1e-5);
}

TEST(splat_respects_ray_interval_and_parallel_rays)
{
    splat_geom g = make(v3(0, 0, -3), v3(1, 0, 0), v3(0, 1, 0));
    float o[3] = {0, 0, 0}, d[3] = {0, 0, -1}, par[3] = {1, 0, 0}, t, r2;
    CHECK(!splat_intersect(&g, o, d, 0, 2.9f, &t, &r2));  /* beyond tfar */
    CHECK(!splat_intersect(&g, o, d, 3.1f, 10, &t, &r2)); /* before tnear */
    CHECK(!splat_intersect(&g, o, par, 0, INFINITY, &t, &r2));
    float back[3] = {0, 0, 1};
    CHECK(!splat_intersect(&g, o, back, 0, INFINITY, &t, &r2)); /* behind origin */
}

TEST(splat_degenerate_axes_are_rejected)
{
    splat_geom g;
    CHECK(splat_geom_init(&g, v3(0, 0, 0), v3(1, 0, 0), v3(2, 0, 0)) != 0);
    CHECK(splat_geom_init(&g, v3(0, 0, 0), v3(0, 0, 0), v3(0, 1, 0)) != 0);
}

TEST(kernel_weight_is_truncated_gaussian)
{
    CHECK_NEAR(splat_kernel_weight(0.0, 0.5), 1.0, 1e-15);
    /* r2 = 0.5, sigma = 0.5: exp(-0.5 / 0.5) = exp(-1) */
    CHECK_NEAR(splat_kernel_weight(0.5, 0.5), exp(-1.0), 1e-15);
    CHECK_NEAR(splat_kernel_weight(1.0, 1.0), exp(-0.5), 1e-15);
    CHECK(splat_kernel_weight(1.0001, 0.5) == 0.0);
}

TEST(splat_bounds_are_the_tight_ellipse_box)
{
    /* circle radius 1 in the plane x = z: u = (1,0,1)/sqrt2, v = (0,1,0):
       extents sqrt(0.5), 1, sqrt(0.5) */
    aabb b = splat_bounds(v3(1, 2, 3), v3(M_SQRT1_2, 0, M_SQRT1_2), v3(0, 1, 0));
    CHECK_NEAR(b.hi.x - 1, M_SQRT1_2, 1e-12);
    CHECK_NEAR(b.hi.y - 2, 1.0, 1e-12);
    CHECK_NEAR(b.lo.z - 3, -M_SQRT1_2, 1e-12);
}

TEST(circular_axes_are_orthogonal_with_the_radius)
{
    vec3 ns[3] = {v3(0, 0, 1), v3(1, 1, 1), v3(-0.2, 0.9, 0.1)};
    for (int i = 0; i < 3; i++) {
        vec3 u, v;
        splat_axes_from_normal(ns[i], 0.7, &u, &v);
        CHECK_NEAR(v3_len(u), 0.7, 1e-12);
        CHECK_NEAR(v3_len(v), 0.7, 1e-12);
        CHECK_NEAR(v3_dot(u, v), 0.0, 1e-12);
        CHECK_NEAR(v3_dot(u, ns[i]), 0.0, 1e-12);
        CHECK_NEAR(v3_dot(v, ns[i]), 0.0, 1e-12);
    }
}
