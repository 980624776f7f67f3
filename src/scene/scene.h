/* In-memory scene description: camera, shutter, lights, objects. Built by
 * scene_xml.c, consumed by accel.c and render.c; knows nothing of either. */
#ifndef RR_SCENE_H
#define RR_SCENE_H

#include <stdint.h>

#include "motion/animation.h"
#include "core/camera.h"
#include "gaussians/gaussian.h"
#include "surfels/pointmodel.h"
#include "surfels/shapes.h"
#include "motion/shutter.h"

typedef enum { SHADING_PHONG, SHADING_UNLIT } shading_kind;

typedef struct {
    shading_kind shading;
    double diffuse;   /* scale of the splat color for ambient and diffuse terms */
    double specular;  /* white specular coefficient */
    double shininess; /* Phong exponent */
} material;

/* README's defaults: Phong, diffuse 1, specular 0, shininess 32. */
static inline material material_default(void)
{
    material m = {SHADING_PHONG, 1.0, 0.0, 32.0};
    return m;
}

/* OBJECT_KIND_COUNT, last, is how many kinds there are: every table
 * indexed by kind has that many rows, which each table asserts at compile
 * time, so that a kind added last without its rows does not build (one
 * inserted before another would leave a zero row the length cannot show:
 * add kinds last). */
typedef enum { OBJECT_POINTS, OBJECT_SPHERE, OBJECT_GAUSSIANS, OBJECT_KIND_COUNT } object_kind;

typedef struct {
    object_kind kind;
    char name[64];
    pointmodel model;  /* OBJECT_POINTS */
    /* where the splats came from, for 'refrender export' (any of the three) */
    char model_file[8192];   /* the PLY read, resolved; "" if none */
    int generated;           /* 1: splats from the generator with these parameters */
    shape_params generator;
    size_t inline_splats;    /* <splat> children */
    gaussian_model gaussians; /* OBJECT_GAUSSIANS: a trained model (alpha-composited, unlit) */
    gaussian_order order;     /* and its 2D hits' compositing order */
    vec3 sphere_center;/* OBJECT_SPHERE, object space */
    double sphere_radius;
    vec3 sphere_color;
    material mat;
    animation anim;
} scene_object;

/* What an object kind is, as one row (scene.c's table, by object_kind):
 * what the layers above ask of an object without testing its kind. The
 * rows of its other operations live beside their code: accel_build.c (how
 * Embree holds it), export_cmd.c (its JSON); scene_xml.c reads each by
 * its element's name. */
typedef struct {
    const char *name;  /* for messages: "a point model", "an analytic sphere", "a Gaussian-splat model" */
    int point_model;   /* 1: splats (surfels): what the splatting comparands draw */
    int gaussians;     /* 1: a Gaussian-splat model (o->gaussians): its BVH is built for each shutter, its hits
                        * composited by the Gaussian integrator, its imaging part of a render's identity */
    size_t (*count)(const scene_object *o); /* its primitives */
    /* Object-space bounds before its animation (scene_object_bounds). */
    aabb (*bounds)(const scene_object *o);
    /* A sphere about its bounds' centre holding it at rest; not for a
     * dynamic Gaussian model, whose paths accel_build.c bounds. */
    void (*rest_sphere)(const scene_object *o, vec3 *center, double *radius);
} scene_object_ops;

/* o's kind's row. */
const scene_object_ops *scene_object_row(const scene_object *o);

/* Scene parameters: -D name=value on the command line, <default> in the
 * file, $name in attribute values (scene_params.c). */
#define SCENE_MAX_PARAMS 32
#define SCENE_PARAM_NAME 64
#define SCENE_PARAM_VALUE 512
typedef struct {
    int n;
    char name[SCENE_MAX_PARAMS][SCENE_PARAM_NAME];
    char value[SCENE_MAX_PARAMS][SCENE_PARAM_VALUE];
    int used[SCENE_MAX_PARAMS];
} scene_params;

typedef enum { LIGHT_POINT, LIGHT_DIRECTIONAL } light_kind;

typedef struct {
    light_kind kind;
    vec3 position;  /* point light */
    vec3 direction; /* directional: the direction light travels (unit) */
    vec3 color;
} light;

typedef struct {
    char path[4096]; /* scene file, for messages and EXR metadata */
    uint64_t scene_hash;  /* content of the scene file (scene_xml.h) */
    uint64_t inputs_hash; /* content of the scene file and every file it names */
    char **inputs;        /* those files' paths (owned), for refusing outputs onto them */
    int ninputs;
    rr_warnings warnings; /* from reading the scene and its files, for the caller to print */
    scene_params params;  /* the parameters applied (given and defaults), for the render's identity */
    camera cam;
    animation camera_motion; /* the camera's rest pose moved like an object (rigid) */
    shutter shut;            /* the shutter this scene is rendered for, its one owner: as the file (or
                                --shutter, --time) gives it, frame 0's with <frames>; a frame's scene
                                (scene_for_shutter) holds that frame's (scene_frame_shutter) */
    double frame_rate;       /* <frames rate>: frame N starts at time N / rate; 0: no frames */
    int frames_at_poses;     /* <frames at="trajectory">: frame N's exposure is centred on the camera
                                trajectory's pose N (a deblurring dataset's frame k spans pose k's
                                time) */
    int sh_eye_fixed;        /* rolling="gsplat" (scene_for_shutter): every Gaussian's SH direction is
                                from sh_eye, not from the camera at the ray's time */
    vec3 sh_eye;
    vec3 background, ambient;
    double epsilon, kernel_sigma;
    int time_factor;
    int nlights, nobjects;
    light *lights;
    scene_object *objects;
} scene;

void scene_init(scene *s);
/* A new object at the end of s's objects: named "object<N>" (N its
 * number from 1), a point model (empty), the default material, static;
 * NULL, s unchanged, when out of memory. Pointers to s's objects hold
 * until the next add. The scene XML and the benchmark make every object
 * so. */
scene_object *scene_add_object(scene *s);
/* l after s's lights; -1, s unchanged, when out of memory. */
int scene_add_light(scene *s, light l);

/* Whether the camera moves during [t0, t1] (then no static-hit reuse). */
int scene_camera_moves(const scene *s);

/* The world ray through raster (x, y) at time t: origin and unit direction,
 * the camera's animation applied. A still camera's is its rest pose's at
 * every t, bit for bit (position, camera_ray_direction): this is the one
 * place that decides it, so callers need not. */
void scene_camera_ray(const scene *s, double x, double y, double t, vec3 *org, vec3 *dir);

/* The camera at time t (its animation applied to the rest pose). */
void scene_camera_view(const scene *s, double t, camera_view *v);

/* World to camera space at time t (4x4, row-major, column vectors; camera
 * space as camera_world_to_camera's): the inverse of the camera's motion
 * at t after its rest pose. The one pose `export` writes and the EXR
 * header's worldToCamera holds (render_attrs.c). */
void scene_world_to_camera(const scene *s, double t, double m[4][4]);

/* [t0, t1]: every instant a line of the camera's image is exposed under
 * the scene's own shutter s->shut (shutter_span at the camera's size:
 * [open, close] for a global shutter; a rolling shutter's lines reach past
 * it). The interval accel's swept bounds cover (accel_build). */
void scene_exposure_span(const scene *s, double *t0, double *t1);

/* The instants of a frame's header poses (README, Output): t[0] and t[2]
 * the first and last instant any line of the image is exposed
 * (scene_exposure_span of fs, the frame's scene) and t[1] the middle
 * between them. Under a rolling shutter the middle line (row or column
 * (L - 1) / 2 of the readout) is exposed around t[1] under every preset,
 * also with --time. */
void scene_exposure_instants(const scene *fs, double t[3]);

/* A frame's camera as its EXR header records it (README, Output): world
 * to camera space at each of scene_exposure_instants, world to NDC (x =
 * raster x / width, y = raster y / height, z = 1 / depth after dividing
 * by w) at the middle one. fs: the scene as the frame renders it
 * (scene_for_shutter: its shutter the frame's; rolling="gsplat" moves its
 * camera). */
typedef struct {
    double time[3];
    double world_to_camera[3][4][4];
    double world_to_ndc[4][4];
} scene_frame_camera;
void scene_frame_camera_of(const scene *fs, scene_frame_camera *out);

/* -1 with err naming the scene, the frame (its label, as for
 * scene_check_shutter_in_trajectory), the time and the value when a matrix
 * of the frame's camera (of s under shutter sh) is beyond the EXR header's
 * float32 (camera_matrix_fits_header): it would be written as infinity. */
int scene_check_frame_camera(const scene *s, const shutter *sh, const char *frame, rr_error *err);

/* Frame N's shutter: s->shut (frame 0's) shifted by N / frame_rate; with
 * frames_at_poses, s->shut shifted so that its middle is the camera
 * trajectory's pose N's time. Returns -1 if the scene has no frames or no
 * pose N. Without --frame or --frames, callers render s->shut itself. */
int scene_frame_shutter(const scene *s, int frame, shutter *out, rr_error *err);
void scene_free(scene *s);

/* The label that names frame N in a message, "frame 3: " (with frames at
 * the trajectory's poses, also the pose time its exposure is centred on),
 * or "" when not numbered (the shutter as given, no --frame). */
void scene_frame_label(const scene *s, long long frame, int numbered, char *buf, size_t size);

/* A note for the user when <frames at="trajectory"> moves the shutter as
 * given (the scene's or --shutter's) onto the poses: 1 with the text in buf
 * (naming frame N's shutter, `first`), 0 when nothing was moved. */
int scene_frame_shutter_note(const scene *s, const shutter *first, long long frame, char *buf, size_t size);

/* A trajectory file holds poses over its own times only: -1 (err names
 * the file, the times and the interpolation's domain) if [open, close]
 * reaches past them, where the camera would be held still. */
int scene_check_trajectory_times(const scene *s, double open, double close, rr_error *err);

/* The rule every command that takes a frame's shutter applies (render and
 * export): every time a line of the camera's image is exposed, with a
 * rolling shutter past [open, close] (shutter_span), lies within the camera
 * trajectory's poses; -1 with err naming the scene, the frame (frame: its
 * label, "frame 3: ", or "" for the shutter as given), the shutter, the
 * lines' times and the trajectory's domain otherwise. */
int scene_check_shutter_in_trajectory(const scene *s, const shutter *sh, const char *frame, rr_error *err);

/* The scene as a frame with shutter sh renders it: *out = *s (sharing
 * everything) with out->shut = *sh, the frame's shutter (the one owner a
 * render, accel and the header read), and under rolling="gsplat" a moving
 * camera moves
 * as gsplat interpolates its start pose (at sh->open) and end pose (open
 * plus the readout: shutter_line_time's last line) and every Gaussian's
 * SH direction starts at the mean of the two poses' centres (gsplat v1.5.3
 * interpolate_shutter_pose and rendering.py:491-494; TRAJECTORIES.md).
 * -1 with err set when those poses cannot be interpolated; free *out with
 * scene_for_shutter_free(out, s), never scene_free. */
int scene_for_shutter(const scene *s, const shutter *sh, scene *out, rr_error *err);
void scene_for_shutter_free(scene *out, const scene *s);

/* Records an input file's path; -1 when out of memory. */
int scene_add_input(scene *s, const char *path);

/* Object-space bounds of an object (before its animation; a Gaussian
 * model's at the kernel radius, without its screen-space filter). A
 * dynamic Gaussian model's at its rest means only: over a shutter its
 * Gaussians' paths reach farther, and accel_build.c bounds those
 * (dynamic_paths); this must not be used for one. */
static inline aabb scene_object_bounds(const scene_object *o) { return scene_object_row(o)->bounds(o); }

#endif
