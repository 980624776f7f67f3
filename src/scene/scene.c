#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/rotation.h"
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
    if (!scene_camera_moves(s)) { /* the rest pose, untouched by an identity transform's rounding */
        *org = s->cam.position, *dir = d;
        return;
    }
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

void scene_world_to_camera(const scene *s, double t, double m[4][4])
{
    double rest[4][4], motion_inv[4][4];
    camera_world_to_camera(&s->cam, rest);
    xform x = animation_at(&s->camera_motion, t);
    vec3 back = xform_inverse_point(&x, v3(0, 0, 0)); /* the inverse motion's translation */
    double tv[3] = {back.x, back.y, back.z};
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k++)
            motion_inv[i][k] = x.ri[i][k];
        motion_inv[i][3] = tv[i];
    }
    motion_inv[3][0] = motion_inv[3][1] = motion_inv[3][2] = 0, motion_inv[3][3] = 1;
    mat4_mul(rest, motion_inv, m);
}

void scene_exposure_span(const scene *s, double *t0, double *t1)
{
    shutter_span(&s->shut, s->cam.width, s->cam.height, t0, t1);
}

void scene_exposure_instants(const scene *fs, double t[3])
{
    scene_exposure_span(fs, &t[0], &t[2]);
    double d = t[2] - t[0]; /* export's middle sample is open + (close - open) * 0.5: the same double */
    t[1] = isfinite(d) ? t[0] + d * 0.5 : 0.5 * t[0] + 0.5 * t[2];
}

void scene_frame_camera_of(const scene *fs, scene_frame_camera *out)
{
    double proj[4][4];
    scene_exposure_instants(fs, out->time);
    for (int i = 0; i < 3; i++)
        scene_world_to_camera(fs, out->time[i], out->world_to_camera[i]);
    camera_projection(&fs->cam, 1.0, 1.0, proj);
    mat4_mul(proj, out->world_to_camera[1], out->world_to_ndc);
}

int scene_check_frame_camera(const scene *s, const shutter *sh, const char *frame, rr_error *err)
{
    scene fs;
    scene_frame_camera fc;
    if (scene_for_shutter(s, sh, &fs, err))
        return -1;
    scene_frame_camera_of(&fs, &fc);
    scene_for_shutter_free(&fs, s);
    double beyond;
    for (int i = 0; i < 3; i++)
        if (!camera_matrix_fits_header(fc.world_to_camera[i], &beyond) ||
            (i == 1 && !camera_matrix_fits_header(fc.world_to_ndc, &beyond)))
            return rr_fail(err, "%s: %sthe camera's pose at time %.17g holds %g in its world-to-camera or "
                                "world-to-NDC matrix, beyond the EXR header's float32 (motion too large)", s->path,
                           frame, fc.time[i], beyond);
    return 0;
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

void scene_frame_label(const scene *s, long long frame, int numbered, char *buf, size_t size)
{
    if (!numbered)
        snprintf(buf, size, "%s", "");
    else if (s->frames_at_poses && frame >= 0 && frame < s->camera_motion.path->count)
        snprintf(buf, size, "frame %lld (its exposure centred on pose %lld's time %.17g): ", frame, frame,
                 s->camera_motion.path->knots[frame].t);
    else
        snprintf(buf, size, "frame %lld: ", frame);
}

int scene_frame_shutter_note(const scene *s, const shutter *first, long long frame, char *buf, size_t size)
{
    if (!s->frames_at_poses || (first->open == s->shut.open && first->close == s->shut.close))
        return 0;
    snprintf(buf, size, "<frames at=\"trajectory\">: each frame's exposure is the shutter [%.9g, %.9g] moved so "
                        "that its middle is its pose's time (frame %lld: [%.9g, %.9g])", s->shut.open,
             s->shut.close, frame, first->open, first->close);
    return 1;
}

/* [open, close] within the trajectory's poses; frame: "" or the frame's
 * label, which the message names */
static int check_times_in_trajectory(const scene *s, double open, double close, const char *frame, rr_error *err)
{
    const trajectory *tr = s->camera_motion.path;
    double t0, t1;
    if (!tr)
        return 0;
    trajectory_domain(tr, &t0, &t1);
    if (open < t0 || close > t1)
        return rr_fail(err, "%s: %sthe shutter [%.17g, %.17g] reaches beyond the camera trajectory %s, whose %s "
                            "interpolation covers [%.17g, %.17g]", s->path, frame, open, close, tr->name,
                       trajectory_interp_name(tr->interp), t0, t1);
    return 0;
}

int scene_check_trajectory_times(const scene *s, double open, double close, rr_error *err)
{
    return check_times_in_trajectory(s, open, close, "", err);
}

int scene_check_shutter_in_trajectory(const scene *s, const shutter *sh, const char *frame, rr_error *err)
{
    const trajectory *tr = s->camera_motion.path;
    double t0, t1, lo, hi;
    if (!tr)
        return 0;
    shutter_span(sh, s->cam.width, s->cam.height, &lo, &hi);
    if (sh->rolling.kind == ROLLING_OFF)
        return check_times_in_trajectory(s, lo, hi, frame, err);
    trajectory_domain(tr, &t0, &t1);
    if (!(lo < t0 || hi > t1))
        return 0;
    /* the lines' times, not [open, close], are what leave the poses */
    return rr_fail(err, "%s: %sthe shutter [%.17g, %.17g] with rolling=\"%s\" exposes lines over [%.17g, %.17g], "
                        "which reaches beyond the camera trajectory %s, whose %s interpolation covers [%.17g, %.17g]",
                   s->path, frame, sh->open, sh->close, shutter_rolling_name(sh->rolling.kind), lo, hi, tr->name,
                   trajectory_interp_name(tr->interp), t0, t1);
}

/* A 2-knot gsplat-interpolated path of the camera's motion from t0 to t1:
 * the knots are the motion's own poses (its transform of the rest camera),
 * so the camera at u is gsplat's pose between the camera's two poses (a
 * fixed rest rotation R0 on the right passes through: slerp(a R0, b R0) =
 * slerp(a, b) R0, and the lerped -R^T p of the posed camera is R0^T times
 * the motion's plus a constant, which the centre -R(u) t(u) takes back). */
static int gsplat_camera_motion(const scene *s, double t0, double t1, animation *out, rr_error *err)
{
    trajectory *tr = calloc(1, sizeof *tr);
    trajectory_knot *k = calloc(2, sizeof *k);
    if (!tr || !k) {
        free(tr), free(k);
        return rr_fail(err, "out of memory");
    }
    tr->interp = TRAJECTORY_GSPLAT, tr->count = 2, tr->knots = k;
    double times[2] = {t0, t1};
    for (int i = 0; i < 2; i++) {
        xform m = animation_pose_at(&s->camera_motion, times[i], k[i].q);
        k[i].t = times[i], k[i].p = m.t;
    }
    animation_init_static(out);
    out->path = tr;
    rr_error why;
    if (trajectory_prepare(tr, "the camera's start and end poses", &why)) {
        animation_free(out);
        return rr_fail(err, "%s: rolling=\"gsplat\" over [%.17g, %.17g]: %s", s->path, t0, t1, why.msg);
    }
    return 0;
}

int scene_for_shutter(const scene *s, const shutter *sh, scene *out, rr_error *err)
{
    *out = *s;
    out->shut = *sh;
    if (sh->rolling.kind != ROLLING_GSPLAT || !scene_camera_moves(s))
        return 0;
    /* the end pose's time: the last line's (shutter_line_time) */
    double t0 = sh->open, t1 = t0 + (sh->rolling.readout_time != 0 ? sh->rolling.readout_time : sh->close - sh->open);
    if (gsplat_camera_motion(s, t0, t1, &out->camera_motion, err))
        return -1;
    const trajectory_knot *k = out->camera_motion.path->knots;
    vec3 c0 = v3_add(k[0].p, quat_rotate(k[0].q, s->cam.position));
    vec3 c1 = v3_add(k[1].p, quat_rotate(k[1].q, s->cam.position));
    out->sh_eye_fixed = 1, out->sh_eye = v3_scale(v3_add(c0, c1), 0.5);
    return 0;
}

void scene_for_shutter_free(scene *out, const scene *s)
{
    if (out->camera_motion.path != s->camera_motion.path)
        animation_free(&out->camera_motion);
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

scene_object *scene_add_object(scene *s)
{
    scene_object *grown = realloc(s->objects, (size_t)(s->nobjects + 1) * sizeof *grown);
    if (!grown)
        return NULL;
    s->objects = grown;
    scene_object *o = &s->objects[s->nobjects++];
    memset(o, 0, sizeof *o);
    pointmodel_init(&o->model);
    gaussian_model_init(&o->gaussians);
    o->mat = material_default();
    animation_init_static(&o->anim);
    snprintf(o->name, sizeof o->name, "object%d", s->nobjects);
    return o;
}

int scene_add_light(scene *s, light l)
{
    light *grown = realloc(s->lights, (size_t)(s->nlights + 1) * sizeof *grown);
    if (!grown)
        return -1;
    s->lights = grown;
    s->lights[s->nlights++] = l;
    return 0;
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

/* ---- the object kinds' rows ---------------------------------------------- */

static size_t points_count(const scene_object *o) { return o->model.count; }
static aabb points_bounds(const scene_object *o) { return o->model.bounds; }

/* About the box's centre, to the farthest corner of any splat's box. */
static void points_sphere(const scene_object *o, vec3 *center, double *radius)
{
    const pointmodel *m = &o->model;
    vec3 c = v3_scale(v3_add(m->bounds.lo, m->bounds.hi), 0.5);
    double r2 = 0;
    for (size_t i = 0; i < m->count; i++) {
        const float *p = m->geom[i].center, *e = &m->extent[3 * i];
        vec3 far = v3(fabs(p[0] - c.x) + e[0], fabs(p[1] - c.y) + e[1], fabs(p[2] - c.z) + e[2]);
        double d2 = v3_dot(far, far); /* farthest corner of the splat's box */
        r2 = d2 > r2 ? d2 : r2;
    }
    *center = c, *radius = sqrt(r2);
}

static size_t sphere_count(const scene_object *o) { return (void)o, 1; }

static aabb sphere_bounds(const scene_object *o)
{
    vec3 r = v3(o->sphere_radius, o->sphere_radius, o->sphere_radius);
    aabb b = {v3_sub(o->sphere_center, r), v3_add(o->sphere_center, r)};
    return b;
}

static void sphere_sphere(const scene_object *o, vec3 *center, double *radius)
{
    *center = o->sphere_center, *radius = o->sphere_radius;
}

static size_t gaussians_count(const scene_object *o) { return o->gaussians.count; }

/* At the kernel radius, without the screen-space filter (accel_build.c
 * gives the filter's footprint its own). */
static aabb gaussians_bounds(const scene_object *o)
{
    aabb b = aabb_empty();
    for (size_t i = 0; i < o->gaussians.count; i++)
        aabb_add_box(&b, gaussian_bounds(&o->gaussians, i, 0.0));
    return b;
}

/* The sphere about the box: half its diagonal. */
static void gaussians_sphere(const scene_object *o, vec3 *center, double *radius)
{
    RR_DCHECK(!o->gaussians.dynamic); /* its rest means are no bound: object_travel (accel_build.c) takes its paths' box */
    aabb b = gaussians_bounds(o);
    *center = v3_scale(v3_add(b.lo, b.hi), 0.5), *radius = 0.5 * v3_len(v3_sub(b.hi, b.lo));
}

static const scene_object_ops object_rows[] = {
    [OBJECT_POINTS] = {"a point model", 1, 0, points_count, points_bounds, points_sphere},
    [OBJECT_SPHERE] = {"an analytic sphere", 0, 0, sphere_count, sphere_bounds, sphere_sphere},
    [OBJECT_GAUSSIANS] = {"a Gaussian-splat model", 0, 1, gaussians_count, gaussians_bounds, gaussians_sphere},
};
_Static_assert(sizeof object_rows / sizeof *object_rows == OBJECT_KIND_COUNT, "an object kind without its row");

const scene_object_ops *scene_object_row(const scene_object *o)
{
    RR_DCHECK((unsigned)o->kind < OBJECT_KIND_COUNT);
    return &object_rows[o->kind];
}
