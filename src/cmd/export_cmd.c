/* 'refrender export': everything another renderer needs to render what
 * refrender renders, as JSON, with no refrender code: camera intrinsics and
 * matrices, each object's model source and object-to-world matrices at
 * sample times of each frame's shutter, a(t), lights, materials. The
 * conventions are written into the file and scripts/README.md (Exporting scenes). */
#include <getopt.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/atomicfile.h"
#include "gaussians/gaussian_dynamic.h"
#include "gaussians/gaussian_hit.h"
#include "cmd/cli.h"
#include "cmd/commands.h"
#include "scenexml/scene_xml.h"
#include "core/rotation.h"
#include "formats/transforms.h"
#include "formats/tum.h"

static void export_usage(FILE *f)
{
    fputs(
"usage: refrender export SCENE.xml [--frame N | --frames A-B] [--shutter O,C] [--times K]\n"
"                        [-D name=value] [--tum PATH.tum [--tum-axes opengl|opencv]]\n"
"                        [--transforms PATH.json] [--tum-rate HZ] [--axes A] -o SCENE.json\n"
"\n"
"Writes the scene as another renderer needs it (scripts/README.md, Exporting):\n"
"resolution, camera intrinsics, and per frame the world-to-camera matrix,\n"
"camera-to-raster matrix and each object's object-to-world matrix at the\n"
"shutter's open and close times and K times between; each object's model\n"
"source (PLY file, generator parameters, inline splat count), material,\n"
"the temporal weight a(t) as parameters and sampled, lights, background.\n"
"  --frame N       frame N of a scene with <frames rate> (default: the\n"
"                  scene's shutter as given)\n"
"  --frames A-B    frames A to B\n"
"  --shutter O,C   shutter interval [O, C] (frame 0's with <frames>), as for\n"
"                  rendering: a(t)'s center and table stay as the scene gives them\n"
"  --times K       sample times per shutter besides open and close (default 8)\n"
"  -D name=value   scene parameter, as for rendering\n"
"  --tum F         also write the camera's path as a TUM trajectory: one line\n"
"                  't tx ty tz qx qy qz qw' (camera-to-world) at each time above,\n"
"                  every frame's; a <trajectory> camera's poses as interpolated\n"
"  --tum-axes A    the camera axes of --tum: opengl (x right, y up, z back;\n"
"                  BAD-Gaussians, the default) or opencv (x right, y down, z forward)\n"
"  --transforms F  the same poses as a nerfstudio transforms.json, with the\n"
"                  camera's intrinsics (one frame a time, 'time' its time)\n"
"  --tum-rate HZ   --tum's and --transforms' poses at the multiples of 1/HZ\n"
"                  from the first frame's open to the last one's close instead:\n"
"                  evenly spaced, as interpolation=\"cubic\" needs (its spline\n"
"                  spans the second pose to the last but one)\n"
"  --axes A        the camera space of the JSON's world_to_camera and\n"
"                  camera_to_raster: refrender (x right, y up, z forward; the\n"
"                  default), opencv (x right, y down, z forward) or opengl\n"
"                  (x right, y up, z back); the JSON's conventions say which\n"
"  -o, --output F  output JSON file (required)\n"
"All outputs are written or none; none may name an input of the scene or\n"
"another output.\n", f);
}

/* --axes: the JSON's camera space, each a flip of one of refrender's axes
 * (src/core/camera.c: x right, y up, z forward). OpenCV's pinhole model has
 * x right, y down, z forward (OpenCV 4.x docs, calib3d, "Camera Calibration
 * and 3D Reconstruction"); OpenGL's eye coordinates x right, y up, the view
 * along -z (gluLookAt(3G): "the direction of view ... mapped to the negative
 * z axis"). */
typedef enum { AXES_REFRENDER, AXES_OPENCV, AXES_OPENGL } camera_axes;
static const char *const AXES_NAMES[] = {"refrender", "opencv", "opengl"};
static const char *const AXES_TEXT[] = {
    "x right, y up, z forward along the view direction (left-handed; --axes refrender)",
    "x right, y down, z forward along the view direction (OpenCV's; --axes opencv)",
    "x right, y up, z backward: the view direction is -z (OpenGL's; --axes opengl)"};
static const int AXES_FLIPPED[] = {-1, 1, 2}; /* the axis negated */

typedef struct {
    const char *scene, *output, *tum, *transforms;
    int tum_opengl; /* --tum-axes */
    camera_axes axes; /* --axes */
    double tum_rate; /* --tum-rate: poses per unit of scene time; 0: at the export's times */
    int frames, first, last, times;
    int shutter_set; /* --shutter */
    double shutter_open, shutter_close;
    scene_params params; /* -D name=value */
} export_options;

static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

static void json_vec3(FILE *f, vec3 v) { fprintf(f, "[%.17g, %.17g, %.17g]", v.x, v.y, v.z); }

/* Row-major nested lists for column vectors: p' = M p. */
static void json_matrix(FILE *f, double m[4][4])
{
    fputc('[', f);
    for (int r = 0; r < 4; r++)
        fprintf(f, "%s[%.17g, %.17g, %.17g, %.17g]", r ? ", " : "", m[r][0], m[r][1], m[r][2], m[r][3]);
    fputc(']', f);
}

/* The affine map p' = r p + t as a 4x4 matrix. */
static void affine_matrix(const double r[3][3], vec3 t, double m[4][4])
{
    double tv[3] = {t.x, t.y, t.z};
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k++)
            m[i][k] = r[i][k];
        m[i][3] = tv[i];
    }
    m[3][0] = m[3][1] = m[3][2] = 0, m[3][3] = 1;
}

static int sample_times(const shutter *sh, int k, double *times)
{
    int n = 0;
    times[n++] = sh->open;
    for (int i = 0; i < k; i++)
        times[n++] = sh->open + (sh->close - sh->open) * ((i + 0.5) / k); /* the fraction first: no overflow */
    times[n++] = sh->close;
    return n;
}

static void write_weight(FILE *f, const shutter *sh)
{
    fprintf(f, "{\"kind\": \"%s\", \"center\": %.17g, \"rate\": %.17g, \"table\": [", shutter_weight_name(sh->kind),
            sh->center, sh->rate);
    for (int i = 0; i < sh->table_size; i++)
        fprintf(f, "%s[%.17g, %.17g]", i ? ", " : "", sh->table_t[i], sh->table_w[i]);
    fputs("], \"samples\": [", f);
    for (int i = 0; i <= 256; i++) {
        double t = sh->open + (sh->close - sh->open) * (i / 256.0);
        fprintf(f, "%s[%.17g, %.17g]", i ? ", " : "", t, shutter_weight(sh, t));
    }
    fputs("]}", f);
}

static int matrix_finite(double m[4][4])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            if (!isfinite(m[r][c]))
                return 0;
    return 1;
}

/* JSON has no number for inf or NaN (a velocity of 1e308 at t = 10 once
 * wrote "inf" into the file): such a transform is refused, naming it. */
static int check_frame(const scene *s, const shutter *sh, const char *frame, const double *times, int n,
                       rr_error *err)
{
    double m[4][4];
    if (scene_check_shutter_in_trajectory(s, sh, frame, err)) /* the render's rule: every line's times */
        return -1;
    for (int i = 0; i < n; i++) {
        scene_world_to_camera(s, times[i], m);
        if (!matrix_finite(m))
            return rr_fail(err, "the camera's transform at time %g is not finite (motion too large)", times[i]);
        for (int o = 0; o < s->nobjects; o++) {
            xform x = animation_at(&s->objects[o].anim, times[i]);
            affine_matrix(x.r, x.t, m);
            if (!matrix_finite(m))
                return rr_fail(err, "object '%s': its transform at time %g is not finite (motion too large)",
                               s->objects[o].name, times[i]);
        }
    }
    return 0;
}

/* F M (F M's rows: world to the --axes camera space) or M F (M's columns:
 * from it), F the diagonal flip of the axis --axes negates. */
static void flip_axes(double m[4][4], camera_axes a, int rows)
{
    int axis = AXES_FLIPPED[a];
    for (int i = 0; i < 4 && axis >= 0; i++)
        rows ? (m[axis][i] = -m[axis][i]) : (m[i][axis] = -m[i][axis]);
}

static void write_rolling(FILE *f, const rolling_shutter *r)
{
    fprintf(f, "{\"kind\": \"%s\"", shutter_rolling_name(r->kind));
    if (r->kind != ROLLING_OFF)
        fprintf(f, ", \"readout\": \"%s\", \"line_delay\": %.17g, \"readout_time\": %.17g",
                shutter_readout_name(r->readout), r->line_delay, r->readout_time);
    fputc('}', f);
}

static int write_frame(FILE *f, const scene *s, long long frame, const export_options *o, const shutter *sh,
                       rr_error *err)
{
    int numbered = o->frames, k = o->times;
    double times[1026], m[4][4];
    if (!isfinite(sh->close - sh->open)) /* every time between would be inf or NaN, blamed on a transform */
        return rr_fail(err, "the shutter [%g, %g] is longer than double precision holds (close - open overflows)",
                       sh->open, sh->close);
    int n = sample_times(sh, k, times);
    char label[128];
    scene_frame_label(s, frame, numbered, label, sizeof label);
    if (check_frame(s, sh, label, times, n, err))
        return -1;
    fputs("    {\"frame\": ", f);
    numbered ? fprintf(f, "%lld", frame) : fputs("null", f);
    fprintf(f, ", \"open\": %.17g, \"close\": %.17g, \"times\": [", sh->open, sh->close);
    for (int i = 0; i < n; i++)
        fprintf(f, "%s%.17g", i ? ", " : "", times[i]);
    fputs("],\n     \"weight\": ", f);
    write_weight(f, sh);
    fputs(",\n     \"rolling_shutter\": ", f);
    write_rolling(f, &sh->rolling);
    fputs(",\n     \"world_to_camera\": [", f);
    scene fs; /* the camera as the render moves it under this shutter (rolling="gsplat": gsplat's poses) */
    if (scene_for_shutter(s, sh, &fs, err))
        return -1;
    for (int i = 0; i < n; i++) {
        scene_world_to_camera(&fs, times[i], m);
        flip_axes(m, o->axes, 1);
        fputs(i ? ", " : "", f);
        json_matrix(f, m);
    }
    scene_for_shutter_free(&fs, s);
    fputs("],\n     \"object_to_world\": {", f);
    for (int o = 0; o < s->nobjects; o++) {
        fputs(o ? ", " : "", f);
        json_string(f, s->objects[o].name);
        fputs(": [", f);
        for (int i = 0; i < n; i++) {
            xform x = animation_at(&s->objects[o].anim, times[i]);
            affine_matrix(x.r, x.t, m);
            fputs(i ? ", " : "", f);
            json_matrix(f, m);
        }
        fputc(']', f);
    }
    fputs("}}", f);
    return 0;
}

/* ---- each object kind's model, one writer a kind (model_writers) ---- */

static void write_gaussians(FILE *f, const scene_object *o)
{
    const gaussian_model *m = &o->gaussians;
    fputs("{\"gaussians\": {\"file\": ", f);
    json_string(f, o->model_file);
    /* a renderer reading the export must know the Gaussians move on their own (the file says how) */
    const char *motion = gaussian_dynamic_name(m);
    fprintf(f, ", \"kind\": \"%s\"", m->kind == GAUSSIAN_3D ? "3dgs" : "2dgs");
    const char *key[GAUSSIAN_IMAGING_FIELDS], *value[GAUSSIAN_IMAGING_FIELDS];
    gaussian_imaging(m, o->order, key, value);
    for (int k = 0; k < GAUSSIAN_IMAGING_FIELDS; k++)
        fprintf(f, ", \"%s\": \"%s\"", key[k], value[k]);
    fprintf(f, ", \"count\": %zu, \"sh_degree\": %d, \"motion\": \"%s\"}}", m->count, m->sh_degree, motion);
}

static void write_sphere(FILE *f, const scene_object *o)
{
    fputs("{\"sphere\": {\"center\": ", f);
    json_vec3(f, o->sphere_center);
    fprintf(f, ", \"radius\": %.17g, \"color\": ", o->sphere_radius);
    json_vec3(f, o->sphere_color);
    fputs("}}", f);
}

static void write_points(FILE *f, const scene_object *o)
{
    fputs("{\"file\": ", f);
    o->model_file[0] ? json_string(f, o->model_file) : fputs("null", f);
    fputs(", \"generator\": ", f);
    if (o->generated) {
        const shape_params *g = &o->generator;
        fputs("{\"shape\": ", f);
        json_string(f, g->kind);
        fprintf(f, ", \"count\": %zu, \"radius\": %.17g, \"minor_radius\": %.17g, \"checker\": %d, "
                   "\"overlap\": %.17g, \"color\": ", g->count, g->radius, g->minor_radius, g->checker, g->overlap);
        json_vec3(f, g->color);
        fputs(", \"color2\": ", f);
        json_vec3(f, g->color2);
        fputs("}", f);
    } else
        fputs("null", f);
    fprintf(f, ", \"inline_splats\": %zu, \"splats\": %zu}", o->inline_splats, o->model.count);
}

/* The export's row of each object kind (by object_kind; what the kind is:
 * scene_object_row). */
static void (*const model_writers[])(FILE *f, const scene_object *o) = {
    [OBJECT_POINTS] = write_points,
    [OBJECT_SPHERE] = write_sphere,
    [OBJECT_GAUSSIANS] = write_gaussians,
};
_Static_assert(sizeof model_writers / sizeof *model_writers == OBJECT_KIND_COUNT, "an object kind without its writer");

static void write_model(FILE *f, const scene_object *o)
{
    RR_DCHECK((unsigned)o->kind < OBJECT_KIND_COUNT);
    model_writers[o->kind](f, o);
}

static void write_objects(FILE *f, const scene *s)
{
    fputs("  \"objects\": [\n", f);
    for (int i = 0; i < s->nobjects; i++) {
        const scene_object *o = &s->objects[i];
        fputs(i ? ",\n    {\"name\": " : "    {\"name\": ", f);
        json_string(f, o->name);
        fputs(", \"rest_offset\": ", f);
        json_vec3(f, o->anim.offset);
        fputs(", \"model\": ", f);
        write_model(f, o);
        fprintf(f, ",\n     \"material\": {\"shading\": \"%s\", \"diffuse\": %.17g, \"specular\": %.17g, "
                   "\"shininess\": %.17g}}",
                o->mat.shading == SHADING_PHONG ? "phong" : "unlit", o->mat.diffuse, o->mat.specular,
                o->mat.shininess);
    }
    fputs("\n  ],\n", f);
}

static void write_lights(FILE *f, const scene *s)
{
    fputs("  \"lights\": [", f);
    for (int i = 0; i < s->nlights; i++) {
        const light *l = &s->lights[i];
        fprintf(f, "%s{\"type\": \"%s\", \"%s\": ", i ? ", " : "", l->kind == LIGHT_POINT ? "point" : "directional",
                l->kind == LIGHT_POINT ? "position" : "direction");
        json_vec3(f, l->kind == LIGHT_POINT ? l->position : l->direction);
        fputs(", \"color\": ", f);
        json_vec3(f, l->color);
        fputc('}', f);
    }
    fputs("],\n", f);
}

static const char *const CONVENTIONS =
    "  \"conventions\": {\n"
    "    \"matrices\": \"4x4, row-major nested lists, for column vectors: p' = M p with p = [x, y, z, 1]\",\n"
    "    \"world\": \"the scene file's coordinates; times in scene time units\",\n"
    "    \"camera_space\": \"%s\",\n"
    "    \"raster\": \"(0, 0) is the image's top-left corner, x right, y down; pixel (i, j) covers "
    "[i, i+1] x [j, j+1], its center at (i + 0.5, j + 0.5)\",\n"
    "    \"camera_to_raster\": \"[X, Y, Z, W] = M [x, y, z, 1]: raster (X / W, Y / W); Z / W = 1 / depth\",\n"
    "    \"object_to_world\": \"maps the model's own coordinates (PLY file, generator output centered at the "
    "origin, inline splats) to world; rest_offset is included\",\n"
    "    \"weight\": \"a(t); a pixel is the integral of a(t) color(t) over [open, close] divided by the "
    "integral of a(t); samples are [t, a(t)]\",\n"
    "    \"rolling_shutter\": \"the scene's <shutter rolling readout lineDelay readoutTime> (scenes/README.md): "
    "kind off, lines (line r's window [open, close] + r line_delay), 3dgs-deblur (readout_time spans the frame) "
    "or gsplat (line r at one instant of the readout); readout the lines' order\"\n"
    "  },\n";

static int write_json(FILE *f, const scene *s, const export_options *o, rr_error *err)
{
    const camera *c = &s->cam;
    double m[4][4];
    fprintf(f, "{\n  \"refrender\": \"%s\",\n  \"scene\": ", RR_VERSION);
    json_string(f, s->path);
    fprintf(f, ",\n  \"inputs_hash\": \"%016llx\",\n", (unsigned long long)s->inputs_hash);
    fprintf(f, CONVENTIONS, AXES_TEXT[o->axes]);
    fprintf(f, "  \"resolution\": [%d, %d],\n  \"camera\": {\"fov_y_degrees\": %.17g, \"position\": ", c->width,
            c->height, c->fov_degrees);
    json_vec3(f, c->position);
    fputs(", \"lookat\": ", f);
    json_vec3(f, c->lookat);
    fputs(", \"up\": ", f);
    json_vec3(f, c->up);
    fprintf(f, ", \"moves\": %s, \"camera_to_raster\": ", scene_camera_moves(s) ? "true" : "false");
    camera_projection(c, c->width, c->height, m); /* to raster */
    flip_axes(m, o->axes, 0);
    json_matrix(f, m);
    fprintf(f, "},\n  \"epsilon\": %.17g,\n  \"kernel_sigma\": %.17g,\n  \"background\": ", s->epsilon,
            s->kernel_sigma);
    json_vec3(f, s->background);
    fputs(",\n  \"ambient\": ", f);
    json_vec3(f, s->ambient);
    fputs(",\n", f);
    write_lights(f, s);
    write_objects(f, s);
    fputs("  \"frames\": [\n", f);
    for (long long fr = o->first; fr <= o->last; fr++) {
        shutter sh = s->shut;
        if (o->frames && scene_frame_shutter(s, (int)fr, &sh, err))
            return -1;
        char note[512];
        if (fr == o->first && o->frames && scene_frame_shutter_note(s, &sh, fr, note, sizeof note))
            fprintf(stderr, "refrender export: note: %s\n", note);
        if (fr > o->first)
            fputs(",\n", f);
        if (write_frame(f, s, fr, o, &sh, err))
            return -1;
    }
    fputs("\n  ]\n}\n", f);
    return 0;
}

typedef struct {
    const scene *s;
    const export_options *o;
} export_job;

/* The camera-to-world pose at t in OpenCV axes (x right, y down, z
 * forward): the motion at t after the rest pose. A <trajectory> camera
 * rests at the identity, so its interpolated pose comes out unchanged. */
static void camera_pose(const scene *s, double t, vec3 *p, double q[4])
{
    const camera *c = &s->cam;
    double rest[3][3], q0[4], qm[4];
    vec3 axes[3] = {c->right, v3_scale(c->image_up, -1.0), c->forward};
    for (int i = 0; i < 3; i++)
        rest[0][i] = axes[i].x, rest[1][i] = axes[i].y, rest[2][i] = axes[i].z;
    quat_of_matrix(rest, q0);
    xform m = animation_pose_at(&s->camera_motion, t, qm);
    *p = v3_add(xform_point(&m, c->position), v3(0, 0, 0)); /* +0 for -0, as the readers keep them */
    quat_mul(qm, q0, q);
    for (int i = 0; i < 4; i++)
        q[i] += 0.0;
}

/* At most this many camera poses in a --tum or --transforms file. */
enum { MAX_PATH_POSES = 1 << 20 };

/* The export's times of every frame, in increasing order, each once (a
 * TUM file's or transforms.json's times increase), in an array of the
 * size the frames and --times need; NULL with err set. */
static double *path_times(const export_job *j, int *count, rr_error *err)
{
    double bound = ((double)j->o->last - j->o->first + 1) * (j->o->times + 2); /* before removing repeats */
    int max = bound < MAX_PATH_POSES ? (int)bound : MAX_PATH_POSES;
    double *out = malloc((size_t)max * sizeof *out);
    if (!out) {
        rr_fail(err, "out of memory");
        return NULL;
    }
    int n = 0;
    for (long long fr = j->o->first; fr <= j->o->last; fr++) {
        shutter sh = j->s->shut;
        double times[1026];
        if (j->o->frames && scene_frame_shutter(j->s, (int)fr, &sh, err)) {
            free(out);
            return NULL;
        }
        int k = sample_times(&sh, j->o->times, times);
        for (int i = 0; i < k; i++) {
            if (n && !(times[i] > out[n - 1]))
                continue;
            if (n == max) {
                free(out);
                rr_fail(err, "more than %d camera poses: export fewer frames or --times", MAX_PATH_POSES);
                return NULL;
            }
            out[n++] = times[i];
        }
    }
    *count = n;
    return out;
}

/* The span [first frame's open, last frame's close]; -1 with err set. */
static int path_span(const export_job *j, double *lo, double *hi, rr_error *err)
{
    *lo = INFINITY, *hi = -INFINITY;
    for (long long fr = j->o->first; fr <= j->o->last; fr++) {
        shutter sh = j->s->shut;
        if (j->o->frames && scene_frame_shutter(j->s, (int)fr, &sh, err))
            return -1;
        *lo = fmin(*lo, sh.open), *hi = fmax(*hi, sh.close);
    }
    return 0;
}

/* --tum-rate R: the times k / R (k an integer) within the export's span.
 * A cubic B-spline (trajectory.c) needs evenly spaced knots; the export's
 * own times (each frame's open, K between, close) are not, across frames
 * or within a frame's ends. Multiples of 1/R rather than the span's open
 * plus steps: two exports of one scene share their knots. */
static double *rate_times(const export_job *j, int *count, rr_error *err)
{
    double lo, hi, rate = j->o->tum_rate;
    if (path_span(j, &lo, &hi, err))
        return NULL;
    /* the multiples k must be exact doubles, and counted in an int: a rate
     * of 1.7e308 made them inf and cast NaN to int (UBSan) */
    if (!(fabs(lo * rate) <= 0x1p53 && fabs(hi * rate) <= 0x1p53)) {
        rr_fail(err, "--tum-rate %g: the exported span [%.17g, %.17g] holds multiples of 1/%g beyond 2^53, where they "
                     "are no longer whole numbers apart: give a lower rate", rate, lo, hi, rate);
        return NULL;
    }
    double first = ceil(lo * rate), last = floor(hi * rate);
    if (first / rate < lo) /* lo * rate rounded down past an integer */
        first += 1;
    if (last / rate > hi)
        last -= 1;
    if (!(last >= first)) {
        rr_fail(err, "--tum-rate %g: no multiple of 1/%g lies in the exported span [%.17g, %.17g]: give a higher "
                     "rate", rate, rate, lo, hi);
        return NULL;
    }
    if (last - first + 1 > MAX_PATH_POSES) {
        rr_fail(err, "--tum-rate %g: %.0f camera poses in [%.17g, %.17g], more than %d", rate, last - first + 1, lo,
                hi, MAX_PATH_POSES);
        return NULL;
    }
    int n = (int)(last - first + 1);
    double *out = malloc((size_t)n * sizeof *out);
    if (!out) {
        rr_fail(err, "out of memory");
        return NULL;
    }
    for (int i = 0; i < n; i++)
        out[i] = (first + i) / rate;
    *count = n;
    return out;
}

/* The times of the poses --tum and --transforms write. */
static double *pose_times(const export_job *j, int *count, rr_error *err)
{
    return j->o->tum_rate > 0 ? rate_times(j, count, err) : path_times(j, count, err);
}

static int write_transforms(FILE *f, void *ctx, rr_error *err)
{
    const export_job *j = ctx;
    int n = 0;
    double *t = pose_times(j, &n, err), (*q)[4] = t ? malloc((size_t)n * sizeof *q + 1) : NULL;
    vec3 *p = q ? malloc((size_t)n * sizeof *p + 1) : NULL;
    int ok = p != NULL;
    if (t && !ok)
        rr_fail(err, "out of memory");
    for (int i = 0; ok && i < n; i++)
        camera_pose(j->s, t[i], &p[i], q[i]);
    if (ok) {
        camera_view v;
        camera_view_rest(&j->s->cam, &v);
        transforms_camera cam = {v.fx, v.fy, v.cx, v.cy, v.width, v.height, NAN, NAN};
        transforms_write(f, &cam, t, p, (const double(*)[4])q, n);
    }
    free(t), free(q), free(p);
    return ok ? 0 : -1;
}

static int write_tum(FILE *f, void *ctx, rr_error *err)
{
    const export_job *j = ctx;
    fprintf(f, "# refrender %s camera path of %s: t tx ty tz qx qy qz qw, camera-to-world, %s axes\n", RR_VERSION,
            j->s->path, j->o->tum_opengl ? "OpenGL (x right, y up, z backward)" : "OpenCV (x right, y down, z forward)");
    int n = 0;
    double *t = pose_times(j, &n, err);
    if (!t)
        return -1;
    for (int i = 0; i < n; i++) {
        vec3 p;
        double q[4];
        camera_pose(j->s, t[i], &p, q);
        tum_write_line(f, t[i], p, q, j->o->tum_opengl);
    }
    free(t);
    return 0;
}

static int write_export(FILE *f, void *ctx, rr_error *err)
{
    const export_job *j = ctx;
    return write_json(f, j->s, j->o, err);
}

/* One file the export writes, and the option that named it. */
typedef struct {
    const char *option, *path;
    int (*write)(FILE *f, void *ctx, rr_error *err);
} export_output;

enum { MAX_EXPORT_OUTPUTS = 3 };
_Static_assert(MAX_EXPORT_OUTPUTS <= ATOMIC_SET_MAX, "an export's outputs are committed as one atomic_set");

/* The outputs asked for, -o's first. */
static int export_outputs(const export_options *o, export_output *out)
{
    int n = 0;
    out[n++] = (export_output){"-o", o->output, write_export};
    if (o->tum)
        out[n++] = (export_output){"--tum", o->tum, write_tum};
    if (o->transforms)
        out[n++] = (export_output){"--transforms", o->transforms, write_transforms};
    return n;
}

/* Before the scene is loaded: each output can be created, and no two name
 * one file however they are spelled (the later would replace the
 * earlier). */
static int check_outputs(const export_output *out, int n, rr_error *err)
{
    for (int i = 0; i < n; i++) {
        if (cli_check_writable(out[i].option, out[i].path, err))
            return -1;
        for (int j = 0; j < i; j++)
            if (cli_same_file(out[i].path, out[j].path))
                return rr_fail(err, "%s %s and %s %s name the same file: each output needs its own",
                               out[j].option, out[j].path, out[i].option, out[i].path);
    }
    return 0;
}

/* No output replaces a file the scene was read from (the scene, its
 * trajectory or transforms.json, models, .anim files). */
static int check_not_inputs(const scene *s, const export_output *out, int n, rr_error *err)
{
    for (int i = 0; i < n; i++)
        for (int k = 0; k < s->ninputs; k++)
            if (cli_same_file(out[i].path, s->inputs[k]))
                return rr_fail(err, "%s %s is an input of this scene (%s): refusing to overwrite it", out[i].option,
                               out[i].path, s->inputs[k]);
    return 0;
}

/* All or nothing: every output is made in full beside its target before
 * any is put in place, so a failure in a later one (a pose limit, a full
 * disk) leaves the earlier ones' files as they were. */
static int write_outputs(const export_output *out, int n, export_job *job, rr_error *err)
{
    atomic_set set = {0};
    for (int i = 0; i < n; i++) {
        char tmp[PATH_MAX + 64];
        if (atomic_prepare_stdio(out[i].path, out[i].write, job, tmp, sizeof tmp, err)) {
            atomic_set_discard(&set);
            return -1;
        }
        atomic_finish(&set, tmp, out[i].path, err);
    }
    return atomic_set_commit(&set, err);
}

static int export_scene(const export_options *o, rr_error *err)
{
    scene s;
    export_output out[MAX_EXPORT_OUTPUTS];
    int n = export_outputs(o, out);
    scene_load_options load = {&o->params, NULL}; /* (no flag: export catches no signal, one ends it) */
    if (check_outputs(out, n, err) || scene_load_file_params(o->scene, &load, &s, err))
        return -1;
    int rc = 0;
    if (o->shutter_set) { /* as the render applies it (render_cmd.c, apply_overrides) */
        s.shut.open = o->shutter_open, s.shut.close = o->shutter_close;
        rc = shutter_check(&s.shut, err);
    }
    export_job job = {&s, o};
    if (!rc)
        rc = check_not_inputs(&s, out, n, err) || write_outputs(out, n, &job, err) ? -1 : 0;
    scene_free(&s);
    return rc;
}

static int parse_axes(const char *text, camera_axes *axes, rr_error *err)
{
    for (int a = AXES_REFRENDER; a <= AXES_OPENGL; a++)
        if (!strcmp(text, AXES_NAMES[a]))
            return *axes = (camera_axes)a, 0;
    return rr_fail(err, "--axes: refrender, opencv or opengl, got '%s'", text);
}

static int parse_export_args(int argc, char **argv, export_options *o, rr_error *err)
{
    static const struct option longopts[] = {{"frame", required_argument, 0, 'f'}, {"frames", required_argument, 0, 'F'},
                                             {"times", required_argument, 0, 't'}, {"output", required_argument, 0, 'o'},
                                             {"shutter", required_argument, 0, 's'},
                                             {"tum", required_argument, 0, 'T'}, {"tum-axes", required_argument, 0, 'A'},
                                             {"transforms", required_argument, 0, 'J'},
                                             {"tum-rate", required_argument, 0, 'R'},
                                             {"axes", required_argument, 0, 'X'},
                                             {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    int c;
    char extra;
    while ((c = getopt_long(argc, argv, "hD:o:", longopts, NULL)) != -1) {
        if (c == 'h')
            return 1;
        if (c == 'D' && scene_params_add(&o->params, optarg, err))
            return -1;
        if (c == 'f' && cli_int("--frame", optarg, INT_MIN, INT_MAX, &o->first, err))
            return -1;
        if (c == 'f')
            o->last = o->first, o->frames = 1;
        if (c == 'F' && (sscanf(optarg, "%d-%d%c", &o->first, &o->last, &extra) != 2 || o->last < o->first))
            return rr_fail(err, "--frames: expected A-B with A <= B, got '%s'", optarg);
        if (c == 'F')
            o->frames = 1;
        if (c == 't' && cli_int("--times", optarg, 0, 1024, &o->times, err))
            return -1;
        if (c == 'o')
            o->output = optarg;
        if (c == 'T')
            o->tum = optarg;
        if (c == 'J')
            o->transforms = optarg;
        if (c == 'R' && cli_double("--tum-rate", optarg, 0.0, &o->tum_rate, err))
            return -1;
        if (c == 'R' && !(o->tum_rate > 0))
            return rr_fail(err, "--tum-rate: expected a number of poses per unit of scene time > 0, got '%s'", optarg);
        if (c == 'A' && strcmp(optarg, "opengl") && strcmp(optarg, "opencv"))
            return rr_fail(err, "--tum-axes: opengl or opencv, got '%s'", optarg);
        if (c == 'A')
            o->tum_opengl = !strcmp(optarg, "opengl");
        if (c == 's' && (o->shutter_set = 1, cli_shutter(optarg, &o->shutter_open, &o->shutter_close, err)))
            return -1;
        if (c == 'X' && parse_axes(optarg, &o->axes, err))
            return -1;
        if (c == '?') {
            cli_suggest_option("refrender export", argv[optind - 1], longopts);
            return rr_fail(err, "unknown option (see 'refrender export --help')");
        }
    }
    if (optind != argc - 1 || !o->output)
        return rr_fail(err, "expected one SCENE.xml and -o FILE.json (see 'refrender export --help')");
    if (o->tum_rate > 0 && !o->tum && !o->transforms)
        return rr_fail(err, "--tum-rate sets the times of --tum's or --transforms' poses: give one of them");
    o->scene = argv[optind];
    return 0;
}

int cmd_export(int argc, char **argv)
{
    static export_options o; /* the parameters make it large: not on the stack */
    o.times = 8, o.tum_opengl = 1;
    rr_error err;
    int rc = parse_export_args(argc, argv, &o, &err);
    if (rc == 1) {
        export_usage(stdout);
        return 0;
    }
    if (rc) {
        fprintf(stderr, "refrender export: %s\n", err.msg);
        return 2;
    }
    if (export_scene(&o, &err)) {
        fprintf(stderr, "refrender export: %s\n", err.msg);
        return 1;
    }
    return 0;
}
