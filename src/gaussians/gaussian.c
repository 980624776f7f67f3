#include "gaussians/gaussian.h"

#include <stdlib.h>
#include <string.h>

#include "core/lanes.h"
#include "surfels/splat.h"
#include "core/rotation.h"
#include "surfels/surfel.h"

/* ---- formations: the scene's names ------------------------------------- */

static const struct {
    gaussian_formation f;
    gaussian_kind kind;
    const char *name;
} formations[] = {
    {GAUSSIAN_FORMATION_2DGS, GAUSSIAN_2D, "2dgs"},
    {GAUSSIAN_FORMATION_2DGS_CENTER_NEAR, GAUSSIAN_2D, "2dgs-center-near"},
    {GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE, GAUSSIAN_2D, "2dgs-unit-circle"},
    {GAUSSIAN_FORMATION_3DGS, GAUSSIAN_3D, "3dgs"},
    {GAUSSIAN_FORMATION_3DGS_ANTIALIASED, GAUSSIAN_3D, "3dgs-antialiased"},
    {GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE, GAUSSIAN_3D, "3dgs-fov-minus-one"},
    {GAUSSIAN_FORMATION_GSPLAT, GAUSSIAN_3D, "gsplat"},
    {GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED, GAUSSIAN_3D, "gsplat-antialiased"},
    {GAUSSIAN_FORMATION_3DGRT, GAUSSIAN_3D, "3dgrt"},
};
enum { FORMATIONS = sizeof formations / sizeof formations[0] };

gaussian_formation gaussian_formation_of(const gaussian_model *m)
{
    if (m->formation != GAUSSIAN_FORMATION_DEFAULT)
        return m->formation;
    return m->kind == GAUSSIAN_3D ? GAUSSIAN_FORMATION_3DGS : GAUSSIAN_FORMATION_2DGS;
}

const char *gaussian_formation_name(gaussian_formation f)
{
    for (int k = 0; k < FORMATIONS; k++)
        if (formations[k].f == f)
            return formations[k].name;
    return NULL;
}

const char *gaussian_order_name(const gaussian_model *m, gaussian_order order)
{
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return "max-response";
    return m->kind == GAUSSIAN_2D && order == GAUSSIAN_ORDER_HIT_DEPTH ? "hit-depth" : "center-depth";
}

void gaussian_imaging(const gaussian_model *m, gaussian_order order, const char *key[GAUSSIAN_IMAGING_FIELDS],
                      const char *value[GAUSSIAN_IMAGING_FIELDS])
{
    key[0] = "semantics", value[0] = gaussian_formation_name(gaussian_formation_of(m));
    key[1] = "tileRule", value[1] = m->tile_rule ? "on" : "off";
    key[2] = "order", value[2] = gaussian_order_name(m, order);
}

int gaussian_formation_parse(const char *name, gaussian_kind kind, gaussian_formation *f)
{
    for (int k = 0; k < FORMATIONS; k++)
        if (!strcmp(formations[k].name, name) && formations[k].kind == kind) {
            *f = formations[k].f;
            return 0;
        }
    return -1;
}

/* n floats on a cache line's boundary (NULL when out of memory): a
 * degree-3 Gaussian's SH (192 bytes) then fills three lines instead of
 * straddling four, and compositing reads a quarter fewer. */
static float *floats_on_lines(size_t n)
{
    void *p = NULL;
    return posix_memalign(&p, 64, n * sizeof(float)) ? NULL : p;
}

int gaussian_model_alloc(gaussian_model *m, size_t n)
{
    m->mean = floats_on_lines(n * 3);
    m->scale = floats_on_lines(n * 3);
    m->rotation = floats_on_lines(n * 4);
    m->opacity = floats_on_lines(n);
    m->sh = floats_on_lines(n * 3 * (size_t)m->sh_coeffs);
    return m->mean && m->scale && m->rotation && m->opacity && m->sh ? 0 : -1;
}

void gaussian_model_init(gaussian_model *m) { memset(m, 0, sizeof *m); }

void gaussian_model_free(gaussian_model *m)
{
    free(m->mean);
    free(m->scale);
    free(m->rotation);
    free(m->opacity);
    free(m->sh);
    if (m->dynamic)
        m->dynamic->ops->free(m->dynamic);
    gaussian_model_init(m);
}

/* Small view-dependent coefficients for the rest bases, a fixed function of
 * the Gaussian, basis and channel: enough to exercise every SH degree. */
static float rest_coefficient(size_t i, int k, int c) { return (float)(0.08 * sin(0.7 * (double)i + 1.3 * k + 2.1 * c)); }

int gaussian_from_surfels(const surfel *s, size_t n, gaussian_kind kind, int degree, gaussian_model *m,
                          rr_error *err)
{
    gaussian_model_free(m);
    if (degree < 0 || degree > GAUSSIAN_MAX_SH_DEGREE)
        return rr_fail(err, "SH degree %d: expected 0 to 3", degree);
    m->kind = kind == GAUSSIAN_3D ? GAUSSIAN_3D : GAUSSIAN_2D;
    m->sh_degree = degree, m->sh_coeffs = (degree + 1) * (degree + 1);
    if (gaussian_model_alloc(m, n ? n : 1))
        return rr_fail(err, "out of memory for %zu Gaussians", n);
    for (size_t i = 0; i < n; i++) {
        vec3 u, v, normal = v3_normalize(s[i].normal);
        splat_axes_from_normal(normal, 1.0, &u, &v);
        double q[4], sigma = 0.5 * s[i].radius; /* refrender's kernel: sigma = 0.5 of the splat radius */
        quat_of_frame(u, v, normal, q);
        float pos[3] = {(float)s[i].center.x, (float)s[i].center.y, (float)s[i].center.z};
        double col[3] = {s[i].color.x, s[i].color.y, s[i].color.z};
        for (int k = 0; k < 3; k++) {
            m->mean[3 * i + k] = pos[k];
            m->scale[3 * i + k] = (float)(k < 2 ? sigma : m->kind == GAUSSIAN_3D ? 0.02 * sigma : 0.0);
            m->sh[3 * i * (size_t)m->sh_coeffs + (size_t)k] = (float)((col[k] - 0.5) / 0.28209479177387814);
        }
        for (int k = 0; k < 4; k++)
            m->rotation[4 * i + k] = (float)q[k];
        m->opacity[i] = 0.95f;
        for (int k = 1; k < m->sh_coeffs; k++)
            for (int c = 0; c < 3; c++)
                m->sh[3 * i * (size_t)m->sh_coeffs + 3 * (size_t)k + (size_t)c] = rest_coefficient(i, k, c);
    }
    m->count = n;
    return 0;
}

/* ---- spherical harmonics ---------------------------------------------- */

/* Real SH normalisation constants of degrees 0 to 3, with the signs of the
 * official sh_utils.py (its degree-1 basis is -C1 y, C1 z, -C1 x). */
static const double C0 = 0.28209479177387814, C1 = 0.4886025119029199;
static const double C2[5] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                             0.5462742152960396};
static const double C3[7] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                             -0.4570457994644658, 1.445305721320277, -0.5900435899266435};

/* The basis functions 0..(degree+1)^2-1 at the unit direction (x, y, z). */
static void sh_basis(int degree, double x, double y, double z, double *b)
{
    b[0] = C0;
    if (degree < 1)
        return;
    b[1] = -C1 * y, b[2] = C1 * z, b[3] = -C1 * x;
    if (degree < 2)
        return;
    double xx = x * x, yy = y * y, zz = z * z;
    b[4] = C2[0] * x * y, b[5] = C2[1] * y * z, b[6] = C2[2] * (2 * zz - xx - yy);
    b[7] = C2[3] * x * z, b[8] = C2[4] * (xx - yy);
    if (degree < 3)
        return;
    b[9] = C3[0] * y * (3 * xx - yy), b[10] = C3[1] * x * y * z, b[11] = C3[2] * y * (4 * zz - xx - yy);
    b[12] = C3[3] * z * (2 * zz - 3 * xx - 3 * yy), b[13] = C3[4] * x * (4 * zz - xx - yy);
    b[14] = C3[5] * z * (xx - yy), b[15] = C3[6] * x * (xx - 3 * yy);
}

/* The three sums of gaussian_sh_color, per channel the products b[k] sh
 * added in the order of k, over a lane type T: SH_SUMS_T sums of
 * SH_CHANNELS_T channels each, three doubles (one channel each) or one v4d
 * (the three channels; its fourth lane unused). The loop over the sums is
 * unrolled so that they stay in registers: in memory (an array indexed in
 * a loop) they cost compositing its time in a profile. */
#define DEFINE_SH_SUMS(T)                                                                          \
    LANES_TARGET_##T static vec3 sh_sums_##T(const float *sh, const double *b, int n)              \
    {                                                                                              \
        T sum[SH_SUMS_##T] = {0};                                                                  \
        for (int k = 0; k < n; k++)                                                                \
            _Pragma("GCC unroll 4") for (int c = 0; c < SH_SUMS_##T; c++)                          \
                sum[c] = sum[c] + b[k] * sh_channels_##T(sh + 3 * k + c * SH_CHANNELS_##T);        \
        return sh_sums_vec3_##T(sum);                                                              \
    }

enum { SH_SUMS_double = 3, SH_CHANNELS_double = 1 };
static inline double sh_channels_double(const float *sh) { return sh[0]; }
static inline vec3 sh_sums_vec3_double(const double sum[3]) { return v3(sum[0], sum[1], sum[2]); }
DEFINE_SH_SUMS(double)

#if RR_LANES
enum { SH_SUMS_v4d = 1, SH_CHANNELS_v4d = 3 };
/* sh[0..2] in lanes 0..2 (the load reads no fourth float) */
RR_LANES_TARGET static inline v4d sh_channels_v4d(const float *sh) { return v4d_load3f(sh); }
RR_LANES_TARGET static inline vec3 sh_sums_vec3_v4d(const v4d sum[1]) { return v3(sum[0][0], sum[0][1], sum[0][2]); }
DEFINE_SH_SUMS(v4d)
#endif

static vec3 sh_sums(const float *sh, const double *b, int n)
{
#if RR_LANES
    if (rr_lanes_available())
        return sh_sums_v4d(sh, b, n);
#endif
    return sh_sums_double(sh, b, n);
}

#ifdef RR_DCHECKS
int gaussian_sh_lanes_differ(const float *sh, int degree, vec3 dir)
{
#if RR_LANES
    if (!rr_lanes_available())
        return 0;
    vec3 d = v3_normalize(dir);
    double b[GAUSSIAN_MAX_SH_COEFFS];
    sh_basis(degree, d.x, d.y, d.z, b);
    int n = (degree + 1) * (degree + 1);
    vec3 lanes = sh_sums_v4d(sh, b, n), scalar = sh_sums_double(sh, b, n);
    return memcmp(&lanes, &scalar, sizeof lanes) != 0;
#else
    (void)sh, (void)degree, (void)dir;
    return 0;
#endif
}
#endif

vec3 gaussian_sh_color(const float *sh, int degree, vec3 dir)
{
    RR_DCHECK(degree >= 0 && degree <= GAUSSIAN_MAX_SH_DEGREE);
    vec3 d = v3_normalize(dir);
    double b[GAUSSIAN_MAX_SH_COEFFS];
    sh_basis(degree, d.x, d.y, d.z, b);
    vec3 sum = sh_sums(sh, b, (degree + 1) * (degree + 1));
    return v3(rr_fmax(sum.x + 0.5, 0.0), rr_fmax(sum.y + 0.5, 0.0), rr_fmax(sum.z + 0.5, 0.0));
}

/* computeColorFromSH_4D (4DGS forward.cu:73-195): block k of S =
 * (degree + 1)^2 coefficients weighted by cos(2 pi k dir_t / duration),
 * the blocks k >= 1 only when the degree is 3 (:123, :142), at most two
 * (:144, :163). */
vec3 gaussian_sh4d_color(const float *sh, int degree, int degree_t, double dir_t, double duration, vec3 dir)
{
    RR_DCHECK(degree >= 0 && degree <= GAUSSIAN_MAX_SH_DEGREE && degree_t >= 0 && degree_t <= 2);
    vec3 d = v3_normalize(dir);
    double b[GAUSSIAN_MAX_SH_COEFFS];
    sh_basis(degree, d.x, d.y, d.z, b);
    int n = (degree + 1) * (degree + 1), blocks = degree == 3 ? degree_t + 1 : 1;
    vec3 sum = sh_sums(sh, b, n);
    for (int k = 1; k < blocks; k++)
        sum = v3_add(sum, v3_scale(sh_sums(sh + (size_t)3 * n * k, b, n), cos(2 * M_PI * k * dir_t / duration)));
    return v3(rr_fmax(sum.x + 0.5, 0.0), rr_fmax(sum.y + 0.5, 0.0), rr_fmax(sum.z + 0.5, 0.0));
}
