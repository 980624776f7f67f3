#include "core/camera.h"

#include <float.h>

/* a / |a| without squaring the components (a length of 1e200 squared
 * overflows to inf and its direction came out 0); 0 for a = 0. */
static vec3 direction_of(vec3 a)
{
    double m = fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z)));
    return m > 0 ? v3_normalize(v3(a.x / m, a.y / m, a.z / m)) : v3(0, 0, 0);
}

/* Position, lookat and up as directions: each failure named, none blamed
 * on up that up did not cause. */
static int camera_frame(camera *c, rr_error *err)
{
    if (!v3_finite(c->position) || !v3_finite(c->lookat) || !v3_finite(c->up))
        return rr_fail(err, "camera position (%g %g %g), lookat (%g %g %g) and up (%g %g %g) must be finite",
                       c->position.x, c->position.y, c->position.z, c->lookat.x, c->lookat.y, c->lookat.z, c->up.x,
                       c->up.y, c->up.z);
    vec3 f = v3_sub(c->lookat, c->position);
    if (!v3_finite(f))
        return rr_fail(err, "camera position (%g %g %g) and lookat (%g %g %g) are too far apart: their difference "
                            "overflows double precision", c->position.x, c->position.y, c->position.z, c->lookat.x,
                       c->lookat.y, c->lookat.z);
    if (f.x == 0 && f.y == 0 && f.z == 0)
        return rr_fail(err, "camera lookat equals position");
    c->forward = direction_of(f);
    vec3 r = v3_cross(c->forward, direction_of(c->up));
    if (!(v3_len(r) > 1e-9)) /* the sine of the angle between up and the view direction */
        return rr_fail(err, "camera up is zero or parallel to the view direction");
    c->right = v3_normalize(r);
    c->image_up = v3_cross(c->right, c->forward);
    return 0;
}

static double tan_half(double fov_degrees) { return tan(fov_degrees * M_PI / 360.0); }

/* camera_view_rest's focal length (pixels) of a field of view over size pixels. */
static double focal_of_fov(double size, double fov_degrees) { return 0.5 * size / tan_half(fov_degrees); }

static void fov_round_trip(const double *fov, double *out, void *size)
{
    double s = *(const double *)size;
    out[0] = 360.0 / M_PI * atan(0.5 * s / focal_of_fov(s, fov[0]));
}

static void principal_round_trip(const double *dx, double *out, void *size)
{
    double s = *(const double *)size;
    out[0] = (0.5 + dx[0]) * s / s - 0.5;
}

double camera_fov_of_focal(double size, double focal)
{
    double fov = 360.0 / M_PI * atan(0.5 * size / focal);
    rr_round_trip_representative(&fov, 1, fov_round_trip, &size);
    return fov;
}

double camera_principal_offset(double size, double centre)
{
    double d = centre / size - 0.5;
    rr_round_trip_representative(&d, 1, principal_round_trip, &size);
    return d;
}

/* The EXR records the camera's matrices in float32 (OpenEXR's m44f: worldToNDC):
 * a scale beyond float's range is written as infinity. Half FLT_MAX leaves room
 * for the 1e-6 by which a field of view's tangent may move (camera_focal_usable). */
static int fits_float_header(double x) { return fabs(x) <= 0.5 * FLT_MAX; }

int camera_focal_usable(double focal, double size)
{
    double t = 0.5 * size / focal, deg = 360.0 / M_PI * atan(t);
    return focal > 0 && deg > 0 && deg < 180 && fabs(tan(deg * M_PI / 360.0) / t - 1) <= 1e-6 &&
           fits_float_header(focal / size);
}

int camera_principal_usable(double focal, double centre, double size)
{
    return camera_focal_usable(focal, 2 * fmax(fabs(centre), fabs(size - centre))) &&
           fits_float_header(centre / size);
}

int camera_matrix_fits_header(double m[4][4], double *beyond)
{
    for (int r = 0; r < 4; r++)
        for (int k = 0; k < 4; k++)
            if (!fits_float_header(m[r][k])) {
                *beyond = m[r][k];
                return 0;
            }
    return 1;
}

/* Every entry of the header's worldToCamera and worldToNDC must be a finite
 * float32: the intrinsics' own rules bound the projection's scale, but a far
 * position (1e9 with a focal length of 1e36) or a tiny XML fov still carry past
 * float's range in the product and would be written as infinity. */
static int header_matrices_fit(const camera *c, rr_error *err)
{
    double view[4][4], proj[4][4], ndc[4][4], beyond;
    camera_world_to_camera(c, view);
    camera_projection(c, 1.0, 1.0, proj);
    mat4_mul(proj, view, ndc);
    if (!camera_matrix_fits_header(view, &beyond) || !camera_matrix_fits_header(ndc, &beyond))
        return rr_fail(err, "camera at position (%g, %g, %g) with fov %g degrees: its worldToCamera "
                       "or worldToNDC holds %g, beyond the EXR header's float32", c->position.x,
                       c->position.y, c->position.z, c->fov_degrees, beyond);
    return 0;
}

int camera_prepare(camera *c, rr_error *err)
{
    if (camera_frame(c, err))
        return -1;
    if (c->width < 1 || c->height < 1)
        return rr_fail(err, "image size must be at least 1x1, got %dx%d", c->width, c->height);
    if ((long long)c->width * c->height > RR_MAX_PIXELS)
        return rr_fail(err, "image size %dx%d has more than the %lld pixels refrender renders", c->width,
                       c->height, RR_MAX_PIXELS);
    if (!(c->fov_degrees > 0 && c->fov_degrees < 180))
        return rr_fail(err, "camera fov must be in (0, 180) degrees, got %g", c->fov_degrees);
    if (c->fov_x_degrees != 0 && !(c->fov_x_degrees > 0 && c->fov_x_degrees < 180))
        return rr_fail(err, "camera horizontal fov must be in (0, 180) degrees, got %g", c->fov_x_degrees);
    c->tan_half_fov = tan_half(c->fov_degrees);
    c->tan_half_fov_x = c->fov_x_degrees > 0 ? tan_half(c->fov_x_degrees)
                                             : c->tan_half_fov * c->width / c->height; /* square pixels */
    return header_matrices_fit(c, err);
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
 * (2 (x / width - dx) - 1) tan_x, y_cam / z_cam = (1 - 2 (y / height - dy)) tan,
 * (dx, dy) the principal point's offset. */
void camera_projection(const camera *c, double sx, double sy, double m[4][4])
{
    double t = c->tan_half_fov;
    for (int r = 0; r < 4; r++)
        for (int k = 0; k < 4; k++)
            m[r][k] = 0;
    m[0][0] = 0.5 * sx / c->tan_half_fov_x, m[0][2] = (0.5 + c->principal_dx) * sx;
    m[1][1] = -0.5 * sy / t, m[1][2] = (0.5 + c->principal_dy) * sy;
    m[2][3] = 1;
    m[3][2] = 1;
}

vec3 camera_ray_direction(const camera *c, double x, double y)
{
    double sx = (2.0 * (x / c->width - c->principal_dx) - 1.0) * c->tan_half_fov_x;
    double sy = (1.0 - 2.0 * (y / c->height - c->principal_dy)) * c->tan_half_fov;
    vec3 d = v3_add(c->forward, v3_add(v3_scale(c->right, sx), v3_scale(c->image_up, sy)));
    return v3_normalize(d);
}

void camera_view_rest(const camera *c, camera_view *v)
{
    v->position = c->position;
    v->axis[0] = c->right;
    v->axis[1] = v3_scale(c->image_up, -1.0);
    v->axis[2] = c->forward;
    /* camera_ray_direction: x_cam / z_cam = (2 (x / width - dx) - 1) tan_x */
    v->fx = 0.5 * c->width / c->tan_half_fov_x, v->fy = 0.5 * c->height / c->tan_half_fov;
    v->cx = (0.5 + c->principal_dx) * c->width, v->cy = (0.5 + c->principal_dy) * c->height;
    v->width = c->width, v->height = c->height;
}
