#include "surfels/shapes.h"

#include <stdlib.h>
#include <string.h>

void shape_params_default(shape_params *p)
{
    memset(p, 0, sizeof *p);
    strcpy(p->kind, "sphere");
    p->count = 20000;
    p->radius = 1.0;
    p->minor_radius = 0.3;
    p->color = rr_default_color();
    p->color2 = rr_default_color2();
    p->checker = 0;
    p->overlap = 1.5;
}

static vec3 checker_color(const shape_params *p, double s, double t)
{
    /* s, t in cell units; cells alternate between color and color2. */
    if (p->checker <= 0)
        return p->color;
    long cell = (long)floor(s) + (long)floor(t);
    return (cell & 1) ? p->color2 : p->color;
}

/* Fibonacci sphere: near-uniform points; each splat's disk has the area of
 * the sphere divided by the count, times overlap^2 so disks close the gaps. */
static void gen_sphere(const shape_params *p, surfel *s, size_t n)
{
    const double golden = M_PI * (3.0 - sqrt(5.0));
    double r = p->overlap * 2.0 * p->radius / sqrt((double)n);
    for (size_t i = 0; i < n; i++) {
        double z = 1.0 - (2.0 * (double)i + 1.0) / (double)n;
        double rho = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = fmod(golden * (double)i, 2.0 * M_PI);
        vec3 dir = v3(rho * cos(phi), rho * sin(phi), z);
        s[i].center = v3_scale(dir, p->radius);
        s[i].normal = dir;
        s[i].radius = r;
        s[i].color = checker_color(p, phi / M_PI * p->checker, acos(z) / M_PI * p->checker);
    }
}

/* Grid on the torus (u around the axis, v around the tube). The splat covers
 * the local grid cell: radius = overlap * half its diagonal. */
static size_t gen_torus(const shape_params *p, surfel *s, size_t n)
{
    double R = p->radius, rt = p->minor_radius;
    size_t nv = (size_t)fmax(3.0, round(sqrt((double)n * rt / R))); /* rt < R: at most sqrt(n) */
    size_t nu = (size_t)fmax(3.0, round((double)n / (double)nv));
    double du = 2 * M_PI / (double)nu, dv = 2 * M_PI / (double)nv;
    size_t k = 0;
    for (size_t i = 0; i < nu && k < n; i++)
        for (size_t j = 0; j < nv && k < n; j++, k++) {
            double u = ((double)i + 0.5) * du, v = ((double)j + 0.5) * dv;
            vec3 nrm = v3(cos(v) * cos(u), cos(v) * sin(u), sin(v));
            double ring = R + rt * cos(v);
            s[k].center = v3(ring * cos(u), ring * sin(u), rt * sin(v));
            s[k].normal = nrm;
            s[k].radius = p->overlap * 0.5 * hypot(du * (R + rt), dv * rt);
            s[k].color = checker_color(p, u / M_PI * p->checker, v / M_PI * p->checker);
        }
    return k;
}

/* Square grid on [-radius, radius]^2 in z = 0, normal +z. */
static size_t gen_plane(const shape_params *p, surfel *s, size_t n)
{
    size_t side = (size_t)fmax(1.0, floor(sqrt((double)n)));
    double cell = 2.0 * p->radius / (double)side;
    size_t k = 0;
    for (size_t j = 0; j < side; j++)
        for (size_t i = 0; i < side; i++, k++) {
            double x = -p->radius + ((double)i + 0.5) * cell;
            double y = -p->radius + ((double)j + 0.5) * cell;
            s[k].center = v3(x, y, 0);
            s[k].normal = v3(0, 0, 1);
            s[k].radius = p->overlap * cell * M_SQRT1_2;
            double c = (double)p->checker / (2.0 * p->radius);
            s[k].color = checker_color(p, (x + p->radius) * c, (y + p->radius) * c);
        }
    return k;
}

int shape_generate(const shape_params *p, surfel **out, size_t *n, rr_error *err)
{
    if (p->count < 1 || p->count > 100000000)
        return rr_fail(err, "splat count must be in [1, 1e8], got %zu", p->count);
    if (!(p->radius > 0) || !(p->overlap > 0) || !(p->minor_radius > 0))
        return rr_fail(err, "shape radius, minor radius and overlap must be positive");
    /* splat sizes and positions must stay in range (pointmodel.h); a torus
     * whose tube is not thinner than its ring is not a ring torus, and its
     * grid size (from the radius ratio) would overflow */
    if (p->radius > 1e12 || p->overlap > 1e3 || p->minor_radius > 1e12)
        return rr_fail(err, "shape radius and minor radius must be at most 1e12, overlap at most 1000");
    if (!strcmp(p->kind, "torus") && !(p->minor_radius < p->radius))
        return rr_fail(err, "torus minor radius %g must be smaller than its radius %g", p->minor_radius, p->radius);
    surfel *s = calloc(p->count, sizeof *s);
    if (!s)
        return rr_fail(err, "out of memory for %zu surfels", p->count);
    size_t made = p->count;
    if (!strcmp(p->kind, "sphere"))
        gen_sphere(p, s, p->count);
    else if (!strcmp(p->kind, "torus"))
        made = gen_torus(p, s, p->count);
    else if (!strcmp(p->kind, "plane"))
        made = gen_plane(p, s, p->count);
    else {
        free(s);
        return rr_fail(err, "unknown shape '%s' (expected sphere, torus or plane)", p->kind);
    }
    *out = s;
    *n = made;
    return 0;
}
