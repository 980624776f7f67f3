/* meshload.c: meshes through Assimp and xyz point clouds, on files written
 * here whose contents are known. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "formats/meshload.h"

static const char *write_file(const char *name, const char *text)
{
    static char path[256];
    snprintf(path, sizeof path, "/tmp/refrender-test-%d-%s", (int)getpid(), name);
    FILE *f = fopen(path, "w");
    fputs(text, f);
    fclose(f);
    return path;
}

TEST(obj_quad_is_two_triangles_on_four_vertices)
{
    const char *p = write_file("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    double *pos = NULL, *nrm = NULL;
    unsigned *tri = NULL;
    size_t nv = 0, nt = 0;
    rr_error e;
    CHECK(meshload_mesh(p, &pos, &nrm, &nv, &tri, &nt, &e) == 0);
    CHECK(nv == 4 && nt == 2);
    double area = 0;
    for (size_t t = 0; t < nt; t++) { /* the triangles cover the unit square */
        const double *a = &pos[3 * tri[3 * t]], *b = &pos[3 * tri[3 * t + 1]], *c = &pos[3 * tri[3 * t + 2]];
        area += 0.5 * fabs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
    }
    CHECK_NEAR(area, 1.0, 1e-12);
    CHECK_NEAR(fabs(nrm[2]), 1.0, 1e-6); /* generated smooth normals: +-z */
    free(pos), free(nrm), free(tri);
    unlink(p);
}

TEST(point_clouds_parse_with_comments_and_name_bad_lines)
{
    CHECK(meshload_is_point_cloud("a.XYZ") && meshload_is_point_cloud("b.pts") && !meshload_is_point_cloud("c.obj"));
    const char *p = write_file("c.xyz", "# header\n0 0 0 0 0 1\n\n1 2 3 0 1 0 # trailing\n");
    double *pos = NULL, *nrm = NULL;
    size_t n = 0;
    rr_error e;
    CHECK(meshload_points(p, &pos, &nrm, &n, &e) == 0 && n == 2);
    if (n == 2)
        CHECK(pos[3] == 1 && pos[5] == 3 && nrm[4] == 1);
    free(pos), free(nrm);
    p = write_file("bad.xyz", "0 0 0 0 0 1\n1 2 3 nan 1 0\n");
    CHECK(meshload_points(p, &pos, &nrm, &n, &e) != 0 && strstr(e.msg, "bad.xyz:2: expected six finite numbers"));
    free(pos), free(nrm);
    unlink(p);
    CHECK(meshload_mesh("/nonexistent/m.obj", &pos, &nrm, &n, NULL, NULL, &e) != 0 && strstr(e.msg, "/nonexistent/m.obj"));
}
