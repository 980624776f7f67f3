#include "camera.h"

int camera_prepare(camera *c, rr_error *err)
{
    vec3 f = v3_sub(c->lookat, c->position);
    if (!isfinite(v3_len(f))) /* its direction would come out 0 and be blamed on up */
        return rr_fail(err, "camera position (%g %g %g) and lookat (%g %g %g) are too far apart: their distance "
                            "overflows", c->position.x, c->position.y, c->position.z, c->lookat.x, c->lookat.y,
                       c->lookat.z);
    if (!(v3_len(f) > 0))
        return rr_fail(err, "camera lookat equals position");
    if (!(c->fov_degrees > 0 && c->fov_degrees < 180))
        return rr_fail(err, "camera fov must be in (0, 180) degrees, got %g", c->fov_degrees);
    if (c->width < 1 || c->height < 1)
        return rr_fail(err, "image size must be at least 1x1, got %dx%d", c->width, c->height);
    if ((long long)c->width * c->height > RR_MAX_PIXELS)
        return rr_fail(err, "image size %dx%d has more than the %lld pixels refrender renders", c->width,
                       c->height, RR_MAX_PIXELS);
    c->forward = v3_normalize(f);
    vec3 r = v3_cross(c->forward, c->up);
    if (!(v3_len(r) > 1e-9 * v3_len(c->up)))
        return rr_fail(err, "camera up is zero or parallel to the view direction");
    c->right = v3_normalize(r);
    c->image_up = v3_cross(c->right, c->forward);
    c->tan_half_fov = tan(c->fov_degrees * M_PI / 360.0);
    return 0;
}

void camera_world_to_camera(const camera *c, double m[4][4])
{
    vec3 axes[3] = {c->right, c->image_up, c->forward};
    for (int r = 0; r < 3; r++) {
        m[r][0] = axes[r].x, m[r][1] = axes[r].y, m[r][2] = axes[r].z;
        m[r][3] = -v3_dot(axes[r], c->position);
    }
    m[3][0] = m[3][1] = m[3][2] = 0, m[3][3] = 1;
}

/* The inverse of camera_ray_direction's mapping: x_cam / z_cam =
 * (2 x / width - 1) tan aspect, y_cam / z_cam = (1 - 2 y / height) tan. */
void camera_projection(const camera *c, double sx, double sy, double m[4][4])
{
    double t = c->tan_half_fov, aspect = (double)c->width / c->height;
    for (int r = 0; r < 4; r++)
        for (int k = 0; k < 4; k++)
            m[r][k] = 0;
    m[0][0] = 0.5 * sx / (t * aspect), m[0][2] = 0.5 * sx;
    m[1][1] = -0.5 * sy / t, m[1][2] = 0.5 * sy;
    m[2][3] = 1;
    m[3][2] = 1;
}

vec3 camera_ray_direction(const camera *c, double x, double y)
{
    double aspect = (double)c->width / (double)c->height;
    double sx = (2.0 * x / c->width - 1.0) * c->tan_half_fov * aspect;
    double sy = (1.0 - 2.0 * y / c->height) * c->tan_half_fov;
    vec3 d = v3_add(c->forward, v3_add(v3_scale(c->right, sx), v3_scale(c->image_up, sy)));
    return v3_normalize(d);
}
