/* The scene XML reader's shared parts (scene_xml.h): the parse context and
 * the attribute helpers (scene_xml_util.c), and the <animation> parser
 * (scene_xml_anim.c). Every error names the file and the element's line. */
#ifndef RR_SCENE_XML_INTERNAL_H
#define RR_SCENE_XML_INTERNAL_H

#include <libxml/parser.h>
#include <signal.h>
#include <stdint.h>

#include "scene/scene.h"

typedef struct {
    const char *name;     /* file name for messages */
    const char *base_dir; /* directory relative paths resolve against */
    uint64_t *inputs_hash;/* every input file's bytes are folded in (inputfile.h) */
    scene *sc;            /* the input files read are recorded (scene_add_input) */
    /* <shutter fraction>, resolved when the frame rate is known (finish_frames) */
    double shutter_fraction; /* of the frame interval; 0: open/close given */
    int shutter_center_given, shutter_line;
    int frames_line; /* <frames at="trajectory">, checked once the camera is read */
    rr_error *err;
    const scene_params *params; /* given on the command line (may be NULL) */
    volatile sig_atomic_t *cancel; /* stops a model's read (scene_load_options; may be NULL) */
} xml_ctx;

const char *xml_elname(xmlNodePtr n);
int xml_is_element(xmlNodePtr n);

/* Parses up to max whitespace-separated finite numbers; returns the count,
 * or -1 if a token is not a finite number. */
int xml_parse_numbers(const char *text, double *out, int max);

int xml_fail(xml_ctx *c, xmlNodePtr n, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Refuses element k, none of the NULL-terminated `known`: "unknown <what>
 * (expected a, b or c)" with the nearest known name; returns -1. */
int xml_unknown_element(xml_ctx *c, xmlNodePtr k, const char *what, const char *const *known);

/* Rejects attributes not in the NULL-terminated list (catches typos). */
int xml_check_attributes(xml_ctx *c, xmlNodePtr n, const char *const *allowed);

/* Copies attribute text into buf; returns 1 if present, 0 if absent, -1
 * (with the error naming the attribute and its length) if it does not fit:
 * a value is never cut. */
int xml_attr_text(xml_ctx *c, xmlNodePtr n, const char *name, char *buf, size_t size);
int xml_has_attr(xmlNodePtr n, const char *name);

/* Up to max finite numbers of the attribute, read whole whatever its
 * length: returns 1 with *count (-1: a token is not a finite number or
 * there are more than max), 0 if absent, -1 on error. */
int xml_attr_number_list(xml_ctx *c, xmlNodePtr n, const char *name, double *out, int max, int *count);

int xml_attr_numbers(xml_ctx *c, xmlNodePtr n, const char *name, double *out, int count,
                        int required);

int xml_attr_double(xml_ctx *c, xmlNodePtr n, const char *name, double *v, int required);

int xml_attr_vec3(xml_ctx *c, xmlNodePtr n, const char *name, vec3 *v, int required);

int xml_attr_positive(xml_ctx *c, xmlNodePtr n, const char *name, double *v, int required);

int xml_attr_int(xml_ctx *c, xmlNodePtr n, const char *name, int *v, int lo, int hi);

/* Non-blank text directly inside the element (a path, as in Figure 4.11)? */
int xml_has_text(xmlNodePtr n);

/* Text children must be whitespace only, except where an element takes a
 * path as its content. */
int xml_check_no_text(xml_ctx *c, xmlNodePtr parent);

/* Resolves rel against the scene's directory; a path that does not fit is
 * an error, never silently cut. */
int xml_resolve_path(xml_ctx *c, xmlNodePtr n, const char *rel, char *out, size_t size);

/* The element's text with surrounding white space removed; 0 if empty,
 * -1 (an error naming the length) if too long for buf. */
int xml_element_text(xml_ctx *c, xmlNodePtr n, char *buf, size_t size);

/* <animation> of an object or the camera: linear/rotation, keyframes or a
 * .anim file (scene_xml_anim.c). */
int xml_parse_animation(xml_ctx *c, xmlNodePtr n, animation *a);

/* Reads the scene's <default>s (removing them), then replaces every $name
 * in every attribute; *applied receives the parameters used (scene_params.c). */
int xml_apply_parameters(xml_ctx *c, xmlNodePtr root, const scene_params *given, scene_params *applied);

/* <camera> (scene_xml_camera.c). */
int xml_parse_camera(xml_ctx *c, xmlNodePtr n, camera *cam, animation *motion);

#endif
