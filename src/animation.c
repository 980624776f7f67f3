#include "animation.h"

void animation_init_static(animation *a)
{
    a->offset = v3(0, 0, 0);
    a->velocity = v3(0, 0, 0);
    a->has_rotation = 0;
    a->axis = v3(0, 0, 1);
    a->center = v3(0, 0, 0);
    a->degrees_per_time = 0;
}

int animation_is_static(const animation *a)
{
    int moves = v3_len(a->velocity) > 0;
    int turns = a->has_rotation && a->degrees_per_time != 0;
    return !moves && !turns;
}

void rotation_matrix(vec3 k, double angle, double r[3][3])
{
    double c = cos(angle), s = sin(angle), C = 1 - c;
    r[0][0] = c + k.x * k.x * C;
    r[0][1] = k.x * k.y * C - k.z * s;
    r[0][2] = k.x * k.z * C + k.y * s;
    r[1][0] = k.y * k.x * C + k.z * s;
    r[1][1] = c + k.y * k.y * C;
    r[1][2] = k.y * k.z * C - k.x * s;
    r[2][0] = k.z * k.x * C - k.y * s;
    r[2][1] = k.z * k.y * C + k.x * s;
    r[2][2] = c + k.z * k.z * C;
}

vec3 xform_vector(const xform *x, vec3 v)
{
    return v3(x->r[0][0] * v.x + x->r[0][1] * v.y + x->r[0][2] * v.z,
              x->r[1][0] * v.x + x->r[1][1] * v.y + x->r[1][2] * v.z,
              x->r[2][0] * v.x + x->r[2][1] * v.y + x->r[2][2] * v.z);
}

vec3 xform_point(const xform *x, vec3 p) { return v3_add(xform_vector(x, p), x->t); }

vec3 xform_inverse_vector(const xform *x, vec3 v)
{
    return v3(x->r[0][0] * v.x + x->r[1][0] * v.y + x->r[2][0] * v.z,
              x->r[0][1] * v.x + x->r[1][1] * v.y + x->r[2][1] * v.z,
              x->r[0][2] * v.x + x->r[1][2] * v.y + x->r[2][2] * v.z);
}

vec3 xform_inverse_point(const xform *x, vec3 p) { return xform_inverse_vector(x, v3_sub(p, x->t)); }

xform animation_at(const animation *a, double t)
{
    xform x;
    double angle = a->has_rotation ? a->degrees_per_time * t * (M_PI / 180.0) : 0.0;
    rotation_matrix(a->axis, angle, x.r);
    /* p' = R (p + offset - c) + c + v t  =>  T = R (offset - c) + c + v t */
    xform rot_only = x;
    rot_only.t = v3(0, 0, 0);
    vec3 rotated = xform_vector(&rot_only, v3_sub(a->offset, a->center));
    x.t = v3_add(v3_add(rotated, a->center), v3_scale(a->velocity, t));
    return x;
}

static void add_transformed_box(aabb *out, const xform *x, aabb b)
{
    for (int i = 0; i < 8; i++) {
        vec3 p = v3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z);
        aabb_add_point(out, xform_point(x, p));
    }
}

aabb animation_swept_bounds(const animation *a, aabb b, double t0, double t1)
{
    aabb out = aabb_empty();
    const int steps = animation_is_static(a) ? 1 : 64;
    for (int i = 0; i <= steps; i++) {
        xform x = animation_at(a, t0 + (t1 - t0) * i / steps);
        add_transformed_box(&out, &x, b);
    }
    if (steps == 1)
        return out;
    /* Between two steps a point moves at most speed * dt / 2 away from the
     * nearer step; speed <= |v| + |omega| * (distance from the axis). */
    vec3 far = v3(0, 0, 0);
    aabb shifted = {v3_add(b.lo, a->offset), v3_add(b.hi, a->offset)};
    double reach = 0;
    for (int i = 0; i < 8; i++) {
        far = v3(i & 1 ? shifted.hi.x : shifted.lo.x, i & 2 ? shifted.hi.y : shifted.lo.y,
                 i & 4 ? shifted.hi.z : shifted.lo.z);
        reach = fmax(reach, v3_len(v3_sub(far, a->center)));
    }
    double omega = a->has_rotation ? fabs(a->degrees_per_time) * M_PI / 180.0 : 0.0;
    double pad = (v3_len(a->velocity) + omega * reach) * (t1 - t0) / steps * 0.5;
    out.lo = v3_sub(out.lo, v3(pad, pad, pad));
    out.hi = v3_add(out.hi, v3(pad, pad, pad));
    return out;
}
