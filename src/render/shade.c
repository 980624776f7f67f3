#include "render/shade.h"

typedef struct {
    vec3 color, normal;
    double lit, diffuse, specular, shininess; /* lit: weight fraction of phong materials */
} blended_surface;

static blended_surface blend(const scene *s, const kbuffer *kb)
{
    blended_surface b = {v3(0, 0, 0), v3(0, 0, 0), 0, 0, 0, 0};
    double wsum = 0;
    for (int i = 0; i < kb->count; i++) { /* sorted order: deterministic sums */
        const surface_hit *h = &kb->hits[i];
        const material *m = &s->objects[h->obj].mat;
        double w = h->weight;
        wsum += w;
        b.color = v3_add(b.color, v3_scale(v3(h->color[0], h->color[1], h->color[2]), w));
        b.normal = v3_add(b.normal, v3_scale(v3(h->normal[0], h->normal[1], h->normal[2]), w));
        b.lit += w * (m->shading == SHADING_PHONG);
        b.diffuse += w * m->diffuse;
        b.specular += w * m->specular;
        b.shininess += w * m->shininess;
    }
    if (!(wsum > 0)) { /* kernel weights underflowed: fall back to the closest hit */
        wsum = 1;
        const surface_hit *h = &kb->hits[0];
        const material *m = &s->objects[h->obj].mat;
        b.color = v3(h->color[0], h->color[1], h->color[2]);
        b.normal = v3(h->normal[0], h->normal[1], h->normal[2]);
        b.lit = m->shading == SHADING_PHONG;
        b.diffuse = m->diffuse, b.specular = m->specular, b.shininess = m->shininess;
    }
    double inv = 1.0 / wsum;
    b.color = v3_scale(b.color, inv);
    b.normal = v3_normalize(b.normal);
    b.lit *= inv, b.diffuse *= inv, b.specular *= inv, b.shininess *= inv;
    return b;
}

static vec3 mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }

/* Phong with lights at infinite (directional) or finite (point) distance,
 * no falloff and no shadows (the thesis' reference does not trace shadows). */
static vec3 phong(const scene *s, const blended_surface *b, vec3 p, vec3 view)
{
    vec3 kd = v3_scale(b->color, b->diffuse);
    vec3 out = mul(kd, s->ambient);
    for (int i = 0; i < s->nlights; i++) {
        const light *l = &s->lights[i];
        vec3 to_light = l->kind == LIGHT_POINT ? v3_normalize(v3_sub(l->position, p))
                                               : v3_scale(l->direction, -1.0);
        double ndotl = v3_dot(b->normal, to_light);
        if (ndotl <= 0)
            continue;
        vec3 r = v3_sub(v3_scale(b->normal, 2.0 * ndotl), to_light);
        double spec = b->specular > 0 ? b->specular * pow(fmax(0.0, v3_dot(r, view)), b->shininess) : 0.0;
        out = v3_add(out, mul(l->color, v3_add(v3_scale(kd, ndotl), v3(spec, spec, spec))));
    }
    return out;
}

vec3 shade_hits(const scene *s, const kbuffer *kb, vec3 org, vec3 dir)
{
    blended_surface b = blend(s, kb);
    if (b.lit <= 0)
        return b.color;
    vec3 p = v3_add(org, v3_scale(dir, kb->closest));
    vec3 lit = phong(s, &b, p, v3_scale(dir, -1.0));
    return v3_add(v3_scale(lit, b.lit), v3_scale(b.color, 1.0 - b.lit));
}
