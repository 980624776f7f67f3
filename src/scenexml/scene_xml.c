#include "scenexml/scene_xml.h"

#include "gaussians/gaussian_hit.h"
#include "scenexml/scene_xml_internal.h"

#include <libxml/parser.h>
#include <libxml/xmlerror.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "formats/animfile.h"
#include "formats/gaussian_ply.h"
#include "core/inputfile.h"
#include "formats/ply.h"
#include "surfels/shapes.h"

/* Splats one generator may make. The fuzz build lowers it (Makefile): a
 * 1e8-splat sphere is a valid scene, but not one input a second. */
#ifndef SCENE_MAX_GENERATED
#define SCENE_MAX_GENERATED 1e8
#endif

/* ---- scene-level elements -------------------------------------------- */


static int parse_weight_kind(xml_ctx *c, xmlNodePtr n, shutter *s)
{
    char kind[64];
    int got = xml_attr_text(c, n, "weight", kind, sizeof kind);
    if (got <= 0)
        return got;
    for (int k = WEIGHT_BOX; k <= WEIGHT_TABLE; k++)
        if (!strcmp(kind, shutter_weight_name((weight_kind)k))) {
            s->kind = (weight_kind)k;
            return 0;
        }
    return xml_fail(c, n, "unknown weight '%s' (expected box, linear, exp or table)", kind);
}

static int parse_weight_table(xml_ctx *c, xmlNodePtr n, shutter *s)
{
    double v[2 * SHUTTER_TABLE_MAX];
    int count, got = xml_attr_number_list(c, n, "table", v, 2 * SHUTTER_TABLE_MAX, &count);
    if (got < 0)
        return -1;
    if (!got) {
        if (s->kind == WEIGHT_TABLE)
            return xml_fail(c, n, "weight 'table' needs a 'table' attribute of 't w' pairs");
        return 0;
    }
    if (count < 2 || count % 2)
        return xml_fail(c, n, "attribute 'table' must hold 1 to 256 't w' number pairs");
    s->table_size = count / 2;
    for (int i = 0; i < s->table_size; i++) {
        s->table_t[i] = v[2 * i];
        s->table_w[i] = v[2 * i + 1];
    }
    return 0;
}

/* rolling="lines|3dgs-deblur|gsplat" readout="top-to-bottom|..."
 * lineDelay="delta" (lines) readoutTime="t_ro" (3dgs-deblur): shutter.h. */
static int parse_rolling(xml_ctx *c, xmlNodePtr n, rolling_shutter *r)
{
    char kind[32] = "off", dir[32] = "top-to-bottom";
    if (xml_attr_text(c, n, "rolling", kind, sizeof kind) < 0 || xml_attr_text(c, n, "readout", dir, sizeof dir) < 0)
        return -1;
    int k = shutter_rolling_parse(kind), d = shutter_readout_parse(dir);
    if (k < 0)
        return xml_fail(c, n, "unknown rolling shutter '%s' (off, lines, 3dgs-deblur or gsplat)", kind);
    if (d < 0)
        return xml_fail(c, n, "unknown readout '%s' (top-to-bottom, bottom-to-top, left-to-right or right-to-left)",
                        dir);
    r->kind = (rolling_kind)k, r->readout = (readout_dir)d;
    if (k == ROLLING_OFF && xml_has_attr(n, "readout"))
        return xml_fail(c, n, "'readout' is for a rolling shutter (rolling=\"lines\", \"3dgs-deblur\" or \"gsplat\")");
    if (xml_has_attr(n, "lineDelay") != (k == ROLLING_LINES))
        return xml_fail(c, n, k == ROLLING_LINES ? "rolling=\"lines\" needs lineDelay (the time between one line's "
                                                   "exposure and the next's)"
                                                 : "lineDelay is for rolling=\"lines\"");
    if (xml_has_attr(n, "readoutTime") != (k == ROLLING_3DGS_DEBLUR))
        return xml_fail(c, n, k == ROLLING_3DGS_DEBLUR ? "rolling=\"3dgs-deblur\" needs readoutTime (its "
                                                         "rolling_shutter_time: first line to last)"
                                                       : "readoutTime is for rolling=\"3dgs-deblur\"");
    return xml_attr_double(c, n, "lineDelay", &r->line_delay, 0) ||
                   xml_attr_double(c, n, "readoutTime", &r->readout_time, 0)
               ? -1 : 0;
}

/* <shutter open close | fraction, weight ...>. With <frames>, times are
 * relative to the start of each frame; fraction is of the frame interval
 * (0.5 = a 180-degree shutter) and is resolved once the rate is known. */
static int parse_shutter(xml_ctx *c, xmlNodePtr n, scene *sc)
{
    static const char *const ok[] = {"open",  "close",   "fraction",  "weight",      "center", "rate",
                                     "table", "rolling", "readout",   "lineDelay",   "readoutTime", NULL};
    shutter *s = &sc->shut;
    if (xml_check_attributes(c, n, ok) || xml_attr_double(c, n, "open", &s->open, 0) ||
        xml_attr_double(c, n, "close", &s->close, 0) || xml_attr_double(c, n, "fraction", &c->shutter_fraction, 0))
        return -1;
    if (xml_has_attr(n, "fraction")) {
        if (xml_has_attr(n, "open") || xml_has_attr(n, "close"))
            return xml_fail(c, n, "give either open/close or fraction, not both");
        if (!(c->shutter_fraction > 0 && c->shutter_fraction <= 1))
            return xml_fail(c, n, "shutter fraction must be in (0, 1]");
        c->shutter_line = (int)xmlGetLineNo(n);
        c->shutter_center_given = xml_has_attr(n, "center");
        s->open = 0, s->close = 1; /* placeholders until the frame rate is known */
    }
    s->center = s->close; /* thesis Figure 3.1: weighting center t_c = t1 */
    if (xml_attr_double(c, n, "center", &s->center, 0) || xml_attr_double(c, n, "rate", &s->rate, 0) ||
        parse_weight_kind(c, n, s) || parse_weight_table(c, n, s) || parse_rolling(c, n, &s->rolling))
        return -1;
    rr_error sub;
    if (shutter_check(s, &sub))
        return xml_fail(c, n, "%s", sub.msg);
    return 0;
}

static int parse_color_element(xml_ctx *c, xmlNodePtr n, vec3 *color)
{
    static const char *const ok[] = {"color", NULL};
    return xml_check_attributes(c, n, ok) || xml_attr_vec3(c, n, "color", color, 1) ? -1 : 0;
}

static int parse_render(xml_ctx *c, xmlNodePtr n, scene *s)
{
    static const char *const ok[] = {"epsilon", "kernel_sigma", "time_factor", NULL};
    if (xml_check_attributes(c, n, ok) || xml_attr_double(c, n, "epsilon", &s->epsilon, 0) ||
        xml_attr_positive(c, n, "kernel_sigma", &s->kernel_sigma, 0) ||
        xml_attr_int(c, n, "time_factor", &s->time_factor, 1, 1024))
        return -1;
    if (s->epsilon < 0)
        return xml_fail(c, n, "attribute 'epsilon' must be >= 0");
    return 0;
}

static int parse_light(xml_ctx *c, xmlNodePtr n, scene *s)
{
    static const char *const ok[] = {"type", "position", "direction", "color", NULL};
    light l = {LIGHT_POINT, v3(0, 0, 0), v3(0, 0, -1), v3(1, 1, 1)};
    char type[64] = "point";
    if (xml_attr_text(c, n, "type", type, sizeof type) < 0 || xml_check_attributes(c, n, ok) ||
        xml_attr_vec3(c, n, "color", &l.color, 0))
        return -1;
    if (!strcmp(type, "point")) {
        if (xml_attr_vec3(c, n, "position", &l.position, 1))
            return -1;
    } else if (!strcmp(type, "directional")) {
        l.kind = LIGHT_DIRECTIONAL;
        if (xml_attr_vec3(c, n, "direction", &l.direction, 1))
            return -1;
        if (!(v3_len(l.direction) > 0))
            return xml_fail(c, n, "light direction must be non-zero");
        l.direction = v3_normalize(l.direction);
    } else {
        return xml_fail(c, n, "unknown light type '%s' (expected point or directional)", type);
    }
    return scene_add_light(s, l) ? xml_fail(c, n, "out of memory") : 0;
}

/* ---- objects ---------------------------------------------------------- */

static int parse_material(xml_ctx *c, xmlNodePtr n, material *m)
{
    static const char *const ok[] = {"shading", "diffuse", "specular", "shininess", NULL};
    char shading[64];
    int got;
    if (xml_check_attributes(c, n, ok) || (got = xml_attr_text(c, n, "shading", shading, sizeof shading)) < 0)
        return -1;
    if (got) {
        if (!strcmp(shading, "phong")) m->shading = SHADING_PHONG;
        else if (!strcmp(shading, "unlit")) m->shading = SHADING_UNLIT;
        else return xml_fail(c, n, "unknown shading '%s' (expected phong or unlit)", shading);
    }
    if (xml_attr_double(c, n, "diffuse", &m->diffuse, 0) || xml_attr_double(c, n, "specular", &m->specular, 0) ||
        xml_attr_double(c, n, "shininess", &m->shininess, 0))
        return -1;
    if (m->diffuse < 0 || m->specular < 0 || m->shininess < 0)
        return xml_fail(c, n, "diffuse, specular and shininess must be >= 0");
    return 0;
}

static int parse_sphere(xml_ctx *c, xmlNodePtr n, scene_object *o)
{
    static const char *const ok[] = {"center", "radius", "color", NULL};
    o->kind = OBJECT_SPHERE;
    o->sphere_center = v3(0, 0, 0);
    o->sphere_color = rr_default_color();
    return xml_check_attributes(c, n, ok) || xml_attr_vec3(c, n, "center", &o->sphere_center, 0) ||
                   xml_attr_positive(c, n, "radius", &o->sphere_radius, 1) ||
                   xml_attr_vec3(c, n, "color", &o->sphere_color, 0)
               ? -1
               : 0;
}

static int parse_splat(xml_ctx *c, xmlNodePtr n, pointmodel *m, vec3 default_color)
{
    static const char *const ok[] = {"center", "normal", "radius", "u", "v", "color", NULL};
    vec3 center = v3(0, 0, 0), normal = v3(0, 0, 0), u = v3(0, 0, 0), v = v3(0, 0, 0);
    vec3 color = default_color;
    double radius = 0;
    if (xml_check_attributes(c, n, ok) || xml_attr_vec3(c, n, "center", &center, 1) ||
        xml_attr_vec3(c, n, "normal", &normal, 0) || xml_attr_vec3(c, n, "color", &color, 0) ||
        xml_attr_double(c, n, "radius", &radius, 0) || xml_attr_vec3(c, n, "u", &u, 0) ||
        xml_attr_vec3(c, n, "v", &v, 0))
        return -1;
    rr_error sub;
    int has_axes = xmlHasProp(n, (const xmlChar *)"u") || xmlHasProp(n, (const xmlChar *)"v");
    int rc = has_axes ? pointmodel_add(m, center, u, v, normal, color, &sub)
                      : pointmodel_add_circle(m, center, normal, radius, color, &sub);
    return rc ? xml_fail(c, n, "%s (give 'normal' and 'radius', or axes 'u' and 'v')", sub.msg) : 0;
}

/* Path from the 'file' attribute or, as in thesis Figure 4.11, the text:
 * 1 found, 0 none, -1 an error (too long: it was cut and then reported as
 * "no splats"). */
static int point_model_path(xml_ctx *c, xmlNodePtr n, char *buf, size_t size)
{
    int got = xml_attr_text(c, n, "file", buf, size);
    return got ? got : xml_element_text(c, n, buf, size);
}

static int generate_shape(xml_ctx *c, xmlNodePtr n, const char *kind, scene_object *o)
{
    pointmodel *m = &o->model;
    shape_params p;
    shape_params_default(&p);
    snprintf(p.kind, sizeof p.kind, "%s", kind);
    double count = (double)p.count;
    if (xml_attr_double(c, n, "count", &count, 0) || xml_attr_positive(c, n, "radius", &p.radius, 0) ||
        xml_attr_positive(c, n, "minor_radius", &p.minor_radius, 0) ||
        xml_attr_vec3(c, n, "color", &p.color, 0) || xml_attr_vec3(c, n, "color2", &p.color2, 0) ||
        xml_attr_int(c, n, "checker", &p.checker, 0, 100000) ||
        xml_attr_positive(c, n, "overlap", &p.overlap, 0))
        return -1;
    if (count < 1 || count > SCENE_MAX_GENERATED || count != floor(count))
        return xml_fail(c, n, "attribute 'count' must be an integer in [1, %g]", (double)SCENE_MAX_GENERATED);
    p.count = (size_t)count;
    o->generated = 1;
    o->generator = p;
    surfel *s;
    size_t ns;
    rr_error sub;
    if (shape_generate(&p, &s, &ns, &sub))
        return xml_fail(c, n, "%s", sub.msg);
    int rc = 0;
    for (size_t i = 0; i < ns && !rc; i++)
        rc = pointmodel_add_circle(m, s[i].center, s[i].normal, s[i].radius, s[i].color, &sub);
    free(s);
    return rc ? xml_fail(c, n, "%s", sub.msg) : 0;
}

/* The scanned models of the scene suite are converted by `make scenes` into
 * scenes/models/ (never committed): a model missing there says how to make
 * it, the first thing a fresh clone runs into. */
static const char *missing_model_hint(const char *path)
{
    const char *dir = strstr(path, "scenes/models/");
    struct stat st;
    if (!dir || (dir != path && dir[-1] != '/') || stat(path, &st) == 0 || errno != ENOENT)
        return "";
    return " (run `make scenes` to convert the scanned models)";
}

/* A model file's reader failed: its message, which element of the scene
 * asked for it, and the hint for a scanned model not yet converted. */
static int model_failed(xml_ctx *c, xmlNodePtr n, const rr_error *sub, const char *element, const char *path)
{
    return rr_fail(c->err, "%s (%s of %s:%ld)%s", sub->msg, element, c->name, xmlGetLineNo(n),
                   missing_model_hint(path));
}

static int parse_point_model(xml_ctx *c, xmlNodePtr n, scene_object *o)
{
    static const char *const ok[] = {"file", "generate", "count", "radius", "minor_radius",
                                     "color", "color2", "checker", "overlap", NULL};
    o->kind = OBJECT_POINTS;
    if (xml_check_attributes(c, n, ok))
        return -1;
    vec3 default_color = rr_default_color();
    if (xml_attr_vec3(c, n, "color", &default_color, 0))
        return -1;
    char rel[4096], path[8192], kind[sizeof ((shape_params *)0)->kind];
    int has_path = point_model_path(c, n, rel, sizeof rel), has_kind;
    if (has_path < 0)
        return -1;
    if (has_path) {
        if (xml_resolve_path(c, n, rel, path, sizeof path))
            return -1;
        rr_error sub;
        if (ply_read(path, default_color, &o->model, c->inputs_hash, c->cancel, &sub))
            return model_failed(c, n, &sub, "point model", path);
        if (scene_add_input(c->sc, path))
            return xml_fail(c, n, "out of memory");
        snprintf(o->model_file, sizeof o->model_file, "%s", path);
    }
    if ((has_kind = xml_attr_text(c, n, "generate", kind, sizeof kind)) < 0 ||
        (has_kind && generate_shape(c, n, kind, o)))
        return -1;
    for (xmlNodePtr k = n->children; k; k = k->next) {
        if (!xml_is_element(k))
            continue;
        if (strcmp(xml_elname(k), "splat"))
            return xml_unknown_element(c, k, "element inside <pointModel>", (const char *const[]){"splat", NULL});
        if (parse_splat(c, k, &o->model, default_color))
            return -1;
        o->inline_splats++;
    }
    if (o->model.count == 0)
        return xml_fail(c, n, "point model has no splats: give a PLY path, 'generate', or "
                               "<splat> children");
    rr_error sub;
    if (pointmodel_sort_spatially(&o->model, NULL, &sub))
        return xml_fail(c, n, "%s", sub.msg);
    return 0;
}

static int parse_gaussian_kind(xml_ctx *c, xmlNodePtr n, gaussian_kind *kind)
{
    char text[16];
    int got = xml_attr_text(c, n, "kind", text, sizeof text);
    if (got <= 0)
        return got;
    if (!strcmp(text, "auto") || !strcmp(text, "2dgs") || !strcmp(text, "3dgs")) {
        *kind = !strcmp(text, "2dgs") ? GAUSSIAN_2D : !strcmp(text, "3dgs") ? GAUSSIAN_3D : GAUSSIAN_AUTO;
        return 0;
    }
    return xml_fail(c, n, "gaussianModel kind must be auto, 2dgs or 3dgs, got '%s'", text);
}

static int parse_gaussian_order(xml_ctx *c, xmlNodePtr n, gaussian_order *order)
{
    char text[16];
    int got = xml_attr_text(c, n, "order", text, sizeof text);
    if (got <= 0)
        return got;
    if (!strcmp(text, "center-depth") || !strcmp(text, "hit-depth")) {
        *order = !strcmp(text, "hit-depth") ? GAUSSIAN_ORDER_HIT_DEPTH : GAUSSIAN_ORDER_CENTER_DEPTH;
        return 0;
    }
    return xml_fail(c, n, "gaussianModel order must be center-depth or hit-depth, got '%s'", text);
}

/* semantics="...": the renderer the model was trained with (gaussian.h's
 * formations; the default is its kind's rasterizer); tileRule="on": only
 * in the rasterizer's tiles. After the model is read (its kind decides). */
static int parse_gaussian_formation(xml_ctx *c, xmlNodePtr n, gaussian_model *m)
{
    char text[32];
    int got = xml_attr_text(c, n, "semantics", text, sizeof text);
    if (got < 0)
        return -1;
    if (got && gaussian_formation_parse(text, m->kind, &m->formation))
        return xml_fail(c, n, "gaussianModel semantics for a %s model must be %s, got '%s'",
                        m->kind == GAUSSIAN_3D ? "3D" : "2D",
                        m->kind == GAUSSIAN_3D ? "3dgs, 3dgs-antialiased, 3dgs-fov-minus-one, gsplat, gsplat-antialiased or 3dgrt"
                                               : "2dgs, 2dgs-center-near or 2dgs-unit-circle", text);
    got = xml_attr_text(c, n, "tileRule", text, sizeof text);
    if (got < 0)
        return -1;
    if (got && strcmp(text, "on") && strcmp(text, "off"))
        return xml_fail(c, n, "gaussianModel tileRule must be on or off, got '%s'", text);
    m->tile_rule = got && !strcmp(text, "on");
    if (m->tile_rule && gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return xml_fail(c, n, "tileRule is a rasterizer's: 3DGRT traces rays and has no tiles");
    return 0;
}

/* <gaussianModel file="point_cloud.ply" kind="auto|2dgs|3dgs"
 * order="center-depth|hit-depth" semantics="..." tileRule="on|off"/>: a
 * trained Gaussian-splat model. */
static int parse_gaussian_model(xml_ctx *c, xmlNodePtr n, scene_object *o)
{
    static const char *const ok[] = {"file", "kind", "order", "semantics", "tileRule", NULL};
    o->kind = OBJECT_GAUSSIANS;
    gaussian_kind kind = GAUSSIAN_AUTO;
    char rel[4096], path[8192];
    int has_path;
    if (xml_check_attributes(c, n, ok) || xml_check_no_text(c, n) || parse_gaussian_kind(c, n, &kind) ||
        parse_gaussian_order(c, n, &o->order) || (has_path = xml_attr_text(c, n, "file", rel, sizeof rel)) < 0)
        return -1;
    if (!has_path)
        return xml_fail(c, n, "gaussianModel needs a 'file' (a trained model's .ply)");
    if (xml_resolve_path(c, n, rel, path, sizeof path))
        return -1;
    rr_error sub;
    if (gaussian_read(path, kind, &o->gaussians, c->inputs_hash, c->cancel, &sub))
        return model_failed(c, n, &sub, "gaussianModel", path);
    if (o->gaussians.kind == GAUSSIAN_3D && xmlHasProp(n, (const xmlChar *)"order"))
        return xml_fail(c, n, "'order' is for 2D Gaussian models: 3D ones go by the centre's view depth (the "
                               "rasterizers) or by the distance to each Gaussian's maximum response (3dgrt)");
    if (parse_gaussian_formation(c, n, &o->gaussians))
        return -1;
    if (scene_add_input(c->sc, path))
        return xml_fail(c, n, "out of memory");
    snprintf(o->model_file, sizeof o->model_file, "%s", path);
    return 0;
}

static int parse_object_child(xml_ctx *c, xmlNodePtr k, scene_object *o, int *shapes)
{
    const char *name = xml_elname(k);
    if (!strcmp(name, "pointModel") || !strcmp(name, "sphere") || !strcmp(name, "gaussianModel")) {
        if (++*shapes > 1)
            return xml_fail(c, k, "an object holds exactly one pointModel, gaussianModel or sphere");
        return !strcmp(name, "sphere")          ? parse_sphere(c, k, o)
               : !strcmp(name, "gaussianModel") ? parse_gaussian_model(c, k, o)
                                                : parse_point_model(c, k, o);
    }
    if (!strcmp(name, "material"))
        return parse_material(c, k, &o->mat);
    if (!strcmp(name, "animation"))
        return xml_parse_animation(c, k, &o->anim);
    static const char *const known[] = {"pointModel", "gaussianModel", "sphere", "material", "animation", NULL};
    return xml_unknown_element(c, k, "element inside <object>", known);
}

static int parse_object(xml_ctx *c, xmlNodePtr n, scene *s)
{
    static const char *const ok[] = {"name", "position", NULL};
    scene_object *o = scene_add_object(s);
    if (!o)
        return xml_fail(c, n, "out of memory");
    if (xml_check_attributes(c, n, ok) || xml_attr_text(c, n, "name", o->name, sizeof o->name) < 0 ||
        xml_attr_vec3(c, n, "position", &o->anim.offset, 0) || xml_check_no_text(c, n))
        return -1;
    int shapes = 0;
    for (xmlNodePtr k = n->children; k; k = k->next)
        if (xml_is_element(k) && parse_object_child(c, k, o, &shapes))
            return -1;
    if (!shapes)
        return xml_fail(c, n, "object has no geometry: add <pointModel>, <gaussianModel> or <sphere>");
    return 0;
}

/* <frames rate="24"/>: frame N starts at scene time N / rate; or
 * <frames at="trajectory"/>: frame N's exposure is centred on the time of
 * the camera trajectory's pose N (a deblurring dataset's blurred frame k
 * spans its pose k's time). */
static int parse_frames(xml_ctx *c, xmlNodePtr n, scene *s)
{
    static const char *const ok[] = {"rate", "at", NULL};
    char at[16] = "";
    if (xml_check_attributes(c, n, ok) || xml_check_no_text(c, n) || xml_attr_text(c, n, "at", at, sizeof at) < 0)
        return -1;
    if (s->frame_rate > 0 || s->frames_at_poses)
        return xml_fail(c, n, "a second <frames>: a scene has one");
    if (*at) {
        if (strcmp(at, "trajectory"))
            return xml_fail(c, n, "<frames at=\"%s\">: the frames can be at=\"trajectory\" (the camera's poses)", at);
        if (xmlHasProp(n, (const xmlChar *)"rate"))
            return xml_fail(c, n, "<frames> takes 'rate' or at=\"trajectory\", not both");
        s->frames_at_poses = 1;
        c->frames_line = (int)xmlGetLineNo(n);
        return 0;
    }
    return xml_attr_positive(c, n, "rate", &s->frame_rate, 1) ? -1 : 0;
}

/* The fraction shutter needs the rate; frame 0's shutter is kept to shift. */
static int finish_frames(xml_ctx *c, scene *s)
{
    if (s->frames_at_poses && !s->camera_motion.path)
        return rr_fail(c->err, "%s:%d: <frames at=\"trajectory\"> needs a <camera> with a <trajectory>", c->name,
                       c->frames_line);
    if (c->shutter_fraction > 0) {
        if (!(s->frame_rate > 0))
            return rr_fail(c->err, "%s:%d: a shutter fraction needs <frames rate=\"...\"/>", c->name,
                           c->shutter_line);
        s->shut.open = 0;
        s->shut.close = c->shutter_fraction / s->frame_rate;
        if (!c->shutter_center_given)
            s->shut.center = s->shut.close;
        rr_error sub;
        if (shutter_check(&s->shut, &sub))
            return rr_fail(c->err, "%s:%d: %s", c->name, c->shutter_line, sub.msg);
    }
    return 0;
}

static int parse_scene_child(xml_ctx *c, xmlNodePtr k, scene *s)
{
    const char *name = xml_elname(k);
    if (!strcmp(name, "camera")) return xml_parse_camera(c, k, &s->cam, &s->camera_motion);
    if (!strcmp(name, "frames")) return parse_frames(c, k, s);
    if (!strcmp(name, "shutter")) return parse_shutter(c, k, s);
    if (!strcmp(name, "background")) return parse_color_element(c, k, &s->background);
    if (!strcmp(name, "ambient")) return parse_color_element(c, k, &s->ambient);
    if (!strcmp(name, "light")) return parse_light(c, k, s);
    if (!strcmp(name, "render")) return parse_render(c, k, s);
    if (!strcmp(name, "object")) return parse_object(c, k, s);
    static const char *const known[] = {"camera", "shutter", "frames", "background", "ambient", "light", "render",
                                        "object", NULL};
    char near[128];
    return xml_fail(c, k, "unknown element (expected camera, shutter, frames, background, ambient, "
                           "light, render or object)%s", rr_did_you_mean(name, known, "<", ">", near, sizeof near));
}

static int parse_scene(xml_ctx *c, xmlDocPtr doc, scene *s)
{
    xmlNodePtr root = xmlDocGetRootElement(doc);
    if (!root || strcmp(xml_elname(root), "scene"))
        return rr_fail(c->err, "%s:%ld: root element must be <scene>", c->name,
                       root ? xmlGetLineNo(root) : 1L);
    static const char *const ok[] = {NULL};
    if (xml_check_attributes(c, root, ok) || xml_check_no_text(c, root) ||
        xml_apply_parameters(c, root, c->params, &s->params))
        return -1;
    if (camera_prepare(&s->cam, c->err))
        return -1;
    for (xmlNodePtr k = root->children; k; k = k->next)
        if (xml_is_element(k) && parse_scene_child(c, k, s))
            return -1;
    if (s->nobjects == 0)
        return rr_fail(c->err, "%s: scene has no <object>", c->name);
    return finish_frames(c, s);
}

/* libxml2 reports through a callback; keep the first error with its line.
 * Some errors (entities) come without a file name: use the scene's. */
typedef struct {
    rr_error first;
    const char *name;
} xml_error_sink;

static void record_xml_error(void *user, xmlErrorPtr e)
{
    xml_error_sink *sink = user;
    if (sink->first.msg[0] || !e)
        return;
    char msg[512];
    snprintf(msg, sizeof msg, "%s", e->message ? e->message : "XML error");
    size_t len = strlen(msg);
    while (len && msg[len - 1] == '\n')
        msg[--len] = 0;
    snprintf(sink->first.msg, sizeof sink->first.msg, "%s:%d: XML syntax error: %s",
             e->file ? e->file : sink->name, e->line > 0 ? e->line : 1, msg);
}

/* XML_PARSE_BIG_LINES: libxml2 otherwise reports every line past 65535 as
 * 65535. The file name is the document's URL, so libxml2's own messages
 * (entities, syntax) name it too. */
int scene_load_memory(const char *xml, size_t len, const char *name, const char *base_dir,
                      scene *s, rr_error *err)
{
    return scene_load_memory_params(xml, len, name, base_dir, NULL, s, err);
}

int scene_load_memory_params(const char *xml, size_t len, const char *name, const char *base_dir,
                             const scene_load_options *opt, scene *s, rr_error *err)
{
    xml_error_sink sink = {{{0}}, name};
    scene_init(s); /* on any error s is left empty, safe to scene_free */
    if (len > SCENE_MAX_BYTES)
        return rr_fail(err, "%s: larger than %zu bytes", name, (size_t)SCENE_MAX_BYTES);
    s->scene_hash = input_hash(INPUT_HASH_INIT, xml, len);
    s->inputs_hash = s->scene_hash;
    xmlSetStructuredErrorFunc(&sink, record_xml_error);
    xmlDocPtr doc = xmlReadMemory(xml, (int)len, name, NULL, XML_PARSE_NONET | XML_PARSE_BIG_LINES);
    xmlSetStructuredErrorFunc(NULL, NULL);
    if (!doc)
        return rr_fail(err, "%s", sink.first.msg[0] ? sink.first.msg : "cannot parse scene");
    snprintf(s->path, sizeof s->path, "%s", name);
    xml_ctx c = {.name = name, .base_dir = base_dir, .inputs_hash = &s->inputs_hash, .sc = s, .err = err,
                 .params = opt ? opt->params : NULL, .cancel = opt ? opt->cancel : NULL};
    int rc = parse_scene(&c, doc, s);
    xmlFreeDoc(doc);
    if (rc)
        scene_free(s);
    return rc;
}

int scene_load_file(const char *path, scene *s, rr_error *err)
{
    return scene_load_file_params(path, NULL, s, err);
}

int scene_load_file_params(const char *path, const scene_load_options *opt, scene *s, rr_error *err)
{
    scene_init(s);
    if (strlen(path) >= sizeof s->path)
        return rr_fail(err, "%.200s...: scene path is too long (%zu characters)", path, strlen(path));
    input_file in;
    rr_error sub;
    if (input_file_read(path, SCENE_MAX_BYTES, &in, &sub))
        return rr_fail(err, "%s (scene file)", sub.msg);
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash)
        *slash = 0;
    else
        strcpy(dir, ".");
    int rc = scene_load_memory_params(in.data, in.len, path, dir, opt, s, err);
    input_file_free(&in);
    if (!rc && scene_add_input(s, path)) {
        scene_free(s);
        return rr_fail(err, "%s: out of memory", path);
    }
    return rc;
}
