/* Mesh and point-cloud surfels: splat sizes on regular grids, worked by hand. */
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "surfels/surfelize.h"

#define N 9 /* grid vertices per side, spacing H */
#define H 0.1

static void grid(double *pos, double *nrm)
{
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            double *p = &pos[3 * (j * N + i)], *n = &nrm[3 * (j * N + i)];
            p[0] = i * H, p[1] = j * H, p[2] = 0;
            n[0] = 0, n[1] = 0, n[2] = 2; /* not unit: made unit */
        }
}

TEST(mesh_splats_have_the_area_of_their_one_ring_share)
{
    double pos[3 * N * N], nrm[3 * N * N];
    unsigned tri[6 * (N - 1) * (N - 1)];
    grid(pos, nrm);
    size_t t = 0;
    for (int j = 0; j + 1 < N; j++)
        for (int i = 0; i + 1 < N; i++) {
            unsigned a = (unsigned)(j * N + i), b = a + 1, c = a + N, d = c + 1;
            unsigned quad[6] = {a, b, d, a, d, c};
            for (int k = 0; k < 6; k++)
                tri[3 * t + k] = quad[k];
            t += 2;
        }
    surfel *s;
    size_t n;
    rr_error e;
    CHECK(surfels_from_mesh(pos, nrm, N * N, tri, t, 1.5, &s, &n, &e) == 0);
    CHECK(n == N * N);
    /* an interior vertex has 6 triangles of area H^2/2 around it: a third of
     * them is H^2, the equal-area disk has radius H / sqrt(pi) */
    const surfel *mid = &s[(N / 2) * N + N / 2];
    CHECK_NEAR(mid->radius, 1.5 * H / sqrt(M_PI), 1e-12);
    CHECK_NEAR(mid->normal.z, 1.0, 1e-15);
    /* a corner with one triangle (b-d-a... the a corner has 2): area H^2/3 */
    CHECK_NEAR(s[0].radius, 1.5 * sqrt(H * H / 3 / M_PI), 1e-12);
    free(s);
    unsigned bad[3] = {0, 1, N * N};
    CHECK(surfels_from_mesh(pos, nrm, N * N, bad, 1, 1.5, &s, &n, &e) == -1);
}

TEST(point_splats_come_from_the_sixth_neighbour)
{
    double pos[3 * N * N], nrm[3 * N * N];
    grid(pos, nrm);
    surfel *s;
    size_t n;
    rr_error e;
    CHECK(surfels_from_points(pos, nrm, N * N, 1.5, &s, &n, &e) == 0);
    CHECK(n == N * N);
    /* interior: 4 neighbours at H, 4 at H sqrt 2; the 6th is at H sqrt 2;
     * area pi d^2 / 7 gives radius d / sqrt 7 */
    CHECK_NEAR(s[(N / 2) * N + N / 2].radius, 1.5 * H * sqrt(2.0) / sqrt(7.0), 1e-12);
    /* a corner: neighbours at H, H, H sqrt2, 2H, 2H, H sqrt5 */
    CHECK_NEAR(s[0].radius, 1.5 * H * sqrt(5.0) / sqrt(7.0), 1e-12);
    free(s);
    CHECK(surfels_from_points(pos, nrm, 5, 1.5, &s, &n, &e) == -1);
}

TEST(checker_colors_alternate_by_cube)
{
    surfel s[2] = {{v3(0.05, 0.05, 0.05), v3(0, 0, 1), 1, v3(0, 0, 0)},
                   {v3(0.15, 0.05, 0.05), v3(0, 0, 1), 1, v3(0, 0, 0)}};
    surfels_color(s, 2, v3(1, 0, 0), v3(0, 1, 0), 0.1);
    CHECK(s[0].color.x == 1 && s[1].color.y == 1);
}

/* A cloud of two points, each given ten times, leaves no
 * splat (every point's 6th nearest neighbour is a duplicate at distance 0);
 * the reason is counted, not 'all points coincide', which they do not. */
TEST(duplicate_points_leave_no_splat_and_say_why)
{
    double pos[20 * 3] = {0}, nrm[20 * 3] = {0};
    for (int i = 0; i < 20; i++) {
        pos[3 * i] = i % 2;        /* (0,0,0) and (1,0,0), ten times each */
        nrm[3 * i + 2] = i != 3;   /* one copy lacks its normal */
    }
    surfel *s = NULL;
    size_t n = 0;
    rr_error e;
    CHECK(surfels_from_points(pos, nrm, 20, 1.5, &s, &n, &e) == -1 && !s);
    CHECK(strstr(e.msg, "no splat is left of 20 points: 1 have no normal and 19 have 6 or more duplicates") != NULL);
}
