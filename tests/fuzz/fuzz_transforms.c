/* libFuzzer target: the nerfstudio transforms.json reader (transforms.c)
 * and every interpolation of what it accepts: poses finite unit
 * quaternions, the camera's intrinsics inside the range rule of
 * camera_focal_usable and camera_principal_usable. */
#include <stdint.h>
#include <stdlib.h>

#include "core/camera.h"
#include "formats/transforms.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    trajectory tr;
    transforms_camera cam;
    rr_error err;
    if (transforms_parse("fuzz.json", (const char *)data, size, &tr, &cam, &err))
        return 0;
    if (!(cam.fx > 0) || !(cam.fy > 0) || !isfinite(cam.cx) || !isfinite(cam.cy) || cam.width < 1 || cam.height < 1 ||
        !camera_focal_usable(cam.fx, cam.width) || !camera_focal_usable(cam.fy, cam.height) ||
        !camera_principal_usable(cam.fx, cam.cx, cam.width) || !camera_principal_usable(cam.fy, cam.cy, cam.height))
        abort();
    for (int k = TRAJECTORY_LINEAR; k <= TRAJECTORY_BEZIER_SE3; k++) {
        tr.interp = (trajectory_interp)k;
        if (trajectory_prepare(&tr, "fuzz.json", &err))
            continue;
        double t0, t1;
        trajectory_domain(&tr, &t0, &t1);
        for (int i = 0; i <= 8; i++) {
            double q[4];
            vec3 p;
            trajectory_pose(&tr, t0 + (t1 - t0) * (i / 8.0), &p, q);
            if (!v3_finite(p) || !(fabs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0) < 1e-6))
                abort();
        }
    }
    trajectory_free(&tr);
    return 0;
}
