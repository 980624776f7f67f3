/* libFuzzer target: the TUM trajectory reader (tum.c) and every
 * interpolation of what it accepts (trajectory.c): a parsed file is
 * prepared under each interpolation, and where accepted its poses must be
 * finite unit quaternions and finite positions across the domain, and what
 * export writes must read back. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "motion/trajectory.h"
#include "formats/tum.h"

static void check_poses(trajectory *tr)
{
    double t0, t1;
    trajectory_domain(tr, &t0, &t1);
    for (int i = 0; i <= 16; i++) {
        double t = t0 + (t1 - t0) * (i / 16.0), q[4];
        vec3 p;
        trajectory_pose(tr, t, &p, q);
        double n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
        if (!v3_finite(p) || !(fabs(n - 1.0) < 1e-6))
            abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    trajectory tr;
    rr_error err;
    if (tum_parse((const char *)data, size, "fuzz.tum", &tr, &err))
        return 0;
    for (int k = TRAJECTORY_LINEAR; k <= TRAJECTORY_BEZIER_SE3; k++) {
        trajectory copy = tr;
        copy.knots = malloc((size_t)tr.count * sizeof *copy.knots + 1);
        if (!copy.knots)
            break;
        for (int i = 0; i < tr.count; i++)
            copy.knots[i] = tr.knots[i];
        copy.interp = (trajectory_interp)k, copy.opengl_axes = k & 1;
        if (!trajectory_prepare(&copy, "fuzz.tum", &err))
            check_poses(&copy);
        free(copy.knots);
    }
    trajectory_free(&tr);
    return 0;
}
