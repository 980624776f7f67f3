/* A 3D Gaussian's hit (gaussian_hit.h): as the 3D rasterizers draw it (the
 * EWA footprint at the ray's pixel, under raster_rules) and as 3DGRT traces
 * it (the ray's closest approach in the canonical frame). */
#include "gaussians/gaussian_hit_internal.h"

/* The image of camera-space point p minus the ray's raster position. */
static void image_offset(const gaussian_ray *r, vec3 p, double *dx, double *dy)
{
    *dx = r->fx * p.x / p.z + r->cx - r->x, *dy = r->fy * p.y / p.z + r->cy - r->y;
}

/* The 3D rasterizers' image of Gaussian i at the ray's pixel (forward.cu
 * preprocessCUDA, computeCov2D, renderCUDA): cov2D = J W Sigma W^T J^T
 * with J at the mean's clamped x/z, y/z; + dilation on the diagonal;
 * power = -d^T cov2D^-1 d / 2 of d = the mean's image - the pixel, skipped
 * above 0; alpha = min(alpha_max, opacity' exp(power)). Sigma in camera
 * space is L L^T with L = M R S (M: object -> camera). 1 and *alpha set,
 * or 0 (culled, or alpha below 1/255). */
static int raster_alpha(const gaussian_model *m, size_t i, const raster_rules *rules, const gaussian_ray *r,
                        vec3 p, double *alpha)
{
    const float *s = &m->scale[3 * i];
    double dx, dy;
    image_offset(r, p, &dx, &dy); /* (the cheap and sure reach test is cull_3d_raster's, run first) */
    double R[3][3], jx, jy, tx, ty;
    raster_jacobian_at(rules, r, p, &jx, &jy, &tx, &ty);
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 j0 = v3(jx / p.z, 0, -jx * tx / p.z), j1 = v3(0, jy / p.z, -jy * ty / p.z);
    double c00 = 0, c01 = 0, c11 = 0;
    for (int a = 0; a < 3; a++) { /* column a of L = M R S, through J */
        vec3 col = v3_scale(cam_vector(r->m, v3(R[0][a], R[1][a], R[2][a])), s[a]);
        double ja = v3_dot(j0, col), jb = v3_dot(j1, col);
        c00 += ja * ja, c01 += ja * jb, c11 += jb * jb;
    }
    double det0 = c00 * c11 - c01 * c01;
    c00 += rules->dilation, c11 += rules->dilation;
    double det = c00 * c11 - c01 * c01;
    if (!(det > 0))
        return 0;
    double power = -0.5 * (c11 * dx * dx + c00 * dy * dy) / det + c01 * dx * dy / det;
    if (power > 0)
        return 0;
    double opacity = m->opacity[i];
    if (rules->antialiased)
        opacity *= sqrt(rr_fmax(rules->aa_floor, det0 / det));
    *alpha = clamp_alpha(rules->alpha_max, opacity, exp(power));
    if (*alpha < GAUSSIAN_ALPHA_MIN)
        return 0;
    if (m->tile_rule && rules->tiles_cut) { /* radius ceil(3 sqrt(lambda_max)), lambda from mid +- sqrt(max(0.1, mid^2 - det)) */
        double mid = 0.5 * (c00 + c11), radius = ceil(3.0 * sqrt(mid + sqrt(rr_fmax(0.1, mid * mid - det))));
        return in_rasterizer_tiles(r, dx + r->x - 0.5, dy + r->y - 0.5, radius);
    }
    return 1;
}

int hit_3d_raster_after_cull(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, gaussian_hit *h)
{
    const raster_rules *rules = raster_rules_of(gaussian_formation_of(m));
    const float *mu = &m->mean[3 * i];
    double alpha, t = p.z / r->depth_per_t; /* the centre's depth: the key and where the bounds hold the ray */
    if (!(p.z > rules->near && p.z <= rules->far) || !(t >= r->tmin && t < r->tmax) || !raster_alpha(m, i, rules, r, p, &alpha))
        return 0;
    vec3 dir = v3_sub(v3(mu[0], mu[1], mu[2]), r->eye);
    *h = (gaussian_hit){(float)t, (float)t, (float)alpha, {(float)dir.x, (float)dir.y, (float)dir.z}, 0, (unsigned)i};
    return 1;
}

/* x in the Gaussian's canonical frame: S^-1 R^T x. */
static vec3 canonical(const double R[3][3], const float *s, vec3 x)
{
    return v3((R[0][0] * x.x + R[1][0] * x.y + R[2][0] * x.z) / s[0],
              (R[0][1] * x.x + R[1][1] * x.y + R[2][1] * x.z) / s[1],
              (R[0][2] * x.x + R[1][2] * x.y + R[2][2] * x.z) / s[2]);
}

int gaussian_hit_3dgrt(const gaussian_model *m, size_t i, const gaussian_ray *r, gaussian_hit *h)
{
    const float *mu = &m->mean[3 * i];
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 o = canonical(R, &m->scale[3 * i], v3_sub(r->org, v3(mu[0], mu[1], mu[2])));
    vec3 d = canonical(R, &m->scale[3 * i], r->dir);
    double dd = v3_dot(d, d);
    if (!(dd > 0))
        return 0;
    double t = -v3_dot(o, d) / dd; /* the closest approach: the maximum response along the ray */
    vec3 closest = v3_add(o, v3_scale(d, t));
    double response = exp(-0.5 * v3_dot(closest, closest));
    double alpha = clamp_alpha(GAUSSIAN_ALPHA_MAX, m->opacity[i], response);
    /* both strict, as gaussianParticles.slang's hit() accepts */
    if (!(response > GAUSSIAN_GRT_MIN_RESPONSE) || !(alpha > GAUSSIAN_ALPHA_MIN) || !(t >= r->tmin && t < r->tmax))
        return 0;
    *h = (gaussian_hit){(float)t, (float)t, (float)alpha, {(float)r->dir.x, (float)r->dir.y, (float)r->dir.z}, 0,
                        (unsigned)i};
    return 1;
}
