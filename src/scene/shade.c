#include "scene/shade.h"

void shade_sums_init(shade_sums *b)
{
    *b = (shade_sums){0, v3(0, 0, 0), v3(0, 0, 0), 0, 0, 0, 0};
}

void shade_sums_add(shade_sums *b, const material *m, const float color[3], const float normal[3], double w)
{
    b->wsum += w;
    b->color = v3_add(b->color, v3_scale(v3(color[0], color[1], color[2]), w));
    b->normal = v3_add(b->normal, v3_scale(v3(normal[0], normal[1], normal[2]), w));
    b->lit += w * (m->shading == SHADING_PHONG);
    b->diffuse += w * m->diffuse;
    b->specular += w * m->specular;
    b->shininess += w * m->shininess;
}

static shade_sums blend(const scene *s, const kbuffer *kb)
{
    shade_sums b;
    shade_sums_init(&b);
    for (int i = 0; i < kb->count; i++) { /* sorted order: deterministic sums */
        const surface_hit *h = &kb->hits[i];
        shade_sums_add(&b, &s->objects[h->obj].mat, h->color, h->normal, h->weight);
    }
    if (!(b.wsum > 0)) { /* kernel weights underflowed: fall back to the closest hit */
        const surface_hit *h = &kb->hits[0];
        shade_sums_init(&b);
        shade_sums_add(&b, &s->objects[h->obj].mat, h->color, h->normal, 1.0);
    }
    return b;
}

static vec3 mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }

/* Phong with lights at infinite (directional) or finite (point) distance,
 * no falloff and no shadows (the thesis' reference does not trace shadows).
 * b holds normalised attributes. */
static vec3 phong(const scene *s, const shade_sums *b, vec3 p, vec3 view)
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

vec3 shade_sums_color(const scene *s, const shade_sums *sums, vec3 org, vec3 dir, double closest)
{
    RR_DCHECK(sums->wsum > 0);
    shade_sums b = *sums;
    double inv = 1.0 / b.wsum;
    b.color = v3_scale(b.color, inv);
    b.normal = v3_normalize(b.normal);
    b.lit *= inv, b.diffuse *= inv, b.specular *= inv, b.shininess *= inv;
    if (b.lit <= 0)
        return b.color;
    vec3 p = v3_add(org, v3_scale(dir, closest));
    vec3 lit = phong(s, &b, p, v3_scale(dir, -1.0));
    return v3_add(v3_scale(lit, b.lit), v3_scale(b.color, 1.0 - b.lit));
}

vec3 shade_hits(const scene *s, const kbuffer *kb, vec3 org, vec3 dir)
{
    shade_sums b = blend(s, kb);
    return shade_sums_color(s, &b, org, dir, kb->closest);
}
