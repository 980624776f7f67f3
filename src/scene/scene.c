#include "scene/scene.h"

#include <stdlib.h>
#include <string.h>

#include "gaussians/gaussian_hit.h"
#include "motion/trajectory.h"

void scene_init(scene *s)
{
    memset(s, 0, sizeof *s);
    s->cam.position = v3(0, 0, 5);
    s->cam.lookat = v3(0, 0, 0);
    s->cam.up = v3(0, 1, 0);
    s->cam.fov_degrees = 45.0;
    s->cam.width = 512;
    s->cam.height = 512;
    shutter_default(&s->shut);
    s->background = v3(0, 0, 0);
    s->ambient = v3(0, 0, 0);
    s->epsilon = 0.01;
    s->kernel_sigma = 0.5;
    s->time_factor = 4;
    animation_init_static(&s->camera_motion);
}

int scene_camera_moves(const scene *s) { return !animation_is_static(&s->camera_motion); }

void scene_camera_ray(const scene *s, double x, double y, double t, vec3 *org, vec3 *dir)
{
    vec3 d = camera_ray_direction(&s->cam, x, y);
    xform m = animation_at(&s->camera_motion, t); /* rigid: keeps d unit */
    *org = xform_point(&m, s->cam.position);
    *dir = xform_vector(&m, d);
}

void scene_camera_view(const scene *s, double t, camera_view *v)
{
    camera_view_rest(&s->cam, v);
    if (!scene_camera_moves(s))
        return;
    xform m = animation_at(&s->camera_motion, t); /* rigid: the axes stay orthonormal */
    v->position = xform_point(&m, v->position);
    for (int k = 0; k < 3; k++)
        v->axis[k] = xform_vector(&m, v->axis[k]);
}

int scene_frame_shutter(const scene *s, int frame, shutter *out, rr_error *err)
{
    double shift;
    if (s->frames_at_poses) {
        const trajectory *tr = s->camera_motion.path; /* the scene reader requires it */
        if (frame < 0 || frame >= tr->count)
            return rr_fail(err, "%s: frame %d: the camera's trajectory has %d poses (frames 0 to %d)", s->path,
                           frame, tr->count, tr->count - 1);
        shift = tr->knots[frame].t - 0.5 * (s->shut.open + s->shut.close);
    } else if (s->frame_rate > 0) {
        shift = frame / s->frame_rate;
    } else {
        return rr_fail(err, "%s: the scene has no frame rate; add <frames rate=\"...\"/> (or at=\"trajectory\") "
                            "to render frames", s->path);
    }
    shutter f = s->shut;
    f.open += shift, f.close += shift, f.center += shift;
    for (int i = 0; i < f.table_size; i++)
        f.table_t[i] += shift;
    *out = f;
    return 0;
}

int scene_check_trajectory_times(const scene *s, double open, double close, rr_error *err)
{
    const trajectory *tr = s->camera_motion.path;
    double t0, t1;
    if (!tr)
        return 0;
    trajectory_domain(tr, &t0, &t1);
    if (open < t0 || close > t1)
        return rr_fail(err, "%s: the shutter [%.17g, %.17g] reaches beyond the camera trajectory %s, whose %s "
                            "interpolation covers [%.17g, %.17g]", s->path, open, close, tr->name,
                       trajectory_interp_name(tr->interp), t0, t1);
    return 0;
}

int scene_check_shutter_in_trajectory(const scene *s, const shutter *sh, rr_error *err)
{
    const trajectory *tr = s->camera_motion.path;
    double t0, t1, lo, hi;
    if (!tr)
        return 0;
    shutter_span(sh, s->cam.width, s->cam.height, &lo, &hi);
    if (sh->rolling.kind == ROLLING_OFF)
        return scene_check_trajectory_times(s, lo, hi, err);
    trajectory_domain(tr, &t0, &t1);
    if (lo < t0 || hi > t1) /* the lines' times, not [open, close], are what leave the poses */
        return rr_fail(err, "%s: the shutter [%.17g, %.17g] with rolling=\"%s\" exposes lines over "
                            "[%.17g, %.17g], which reaches beyond the camera trajectory %s, whose %s interpolation "
                            "covers [%.17g, %.17g]", s->path, sh->open, sh->close,
                       shutter_rolling_name(sh->rolling.kind), lo, hi, tr->name, trajectory_interp_name(tr->interp),
                       t0, t1);
    return 0;
}

void scene_free(scene *s)
{
    for (int i = 0; i < s->nobjects; i++) {
        pointmodel_free(&s->objects[i].model);
        gaussian_model_free(&s->objects[i].gaussians);
        animation_free(&s->objects[i].anim);
    }
    animation_free(&s->camera_motion);
    for (int i = 0; i < s->ninputs; i++)
        free(s->inputs[i]);
    free(s->inputs);
    s->inputs = NULL;
    s->ninputs = 0;
    free(s->objects);
    free(s->lights);
    s->objects = NULL;
    s->lights = NULL;
    s->nobjects = s->nlights = 0;
}

int scene_add_input(scene *s, const char *path)
{
    char **grown = realloc(s->inputs, (size_t)(s->ninputs + 1) * sizeof *grown);
    if (!grown)
        return -1;
    s->inputs = grown;
    if (!(s->inputs[s->ninputs] = strdup(path)))
        return -1;
    s->ninputs++;
    return 0;
}

aabb scene_object_bounds(const scene_object *o)
{
    if (o->kind == OBJECT_POINTS)
        return o->model.bounds;
    if (o->kind == OBJECT_GAUSSIANS) {
        aabb b = aabb_empty();
        for (size_t i = 0; i < o->gaussians.count; i++)
            aabb_add_box(&b, gaussian_bounds(&o->gaussians, i, 0.0));
        return b;
    }
    vec3 r = v3(o->sphere_radius, o->sphere_radius, o->sphere_radius);
    aabb b = {v3_sub(o->sphere_center, r), v3_add(o->sphere_center, r)};
    return b;
}
