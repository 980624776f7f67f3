/* <animation>: linear and rotation, inline <keyframes>, and Maya .anim
 * files (thesis sec. 4.6, Figure 4.11). */
#include "scenexml/scene_xml_internal.h"

#include <stdlib.h>
#include <string.h>

#include "formats/animfile.h"

static int parse_linear(xml_ctx *c, xmlNodePtr n, animation *a)
{
    static const char *const ok[] = {"velocity", NULL};
    return xml_check_attributes(c, n, ok) || xml_attr_vec3(c, n, "velocity", &a->velocity, 1) ? -1 : 0;
}

static int parse_rotation(xml_ctx *c, xmlNodePtr n, animation *a)
{
    static const char *const ok[] = {"axis", "center", "degrees_per_unit_time", NULL};
    if (xml_check_attributes(c, n, ok) || xml_attr_vec3(c, n, "axis", &a->axis, 1) ||
        xml_attr_vec3(c, n, "center", &a->center, 0) ||
        xml_attr_double(c, n, "degrees_per_unit_time", &a->degrees_per_time, 1))
        return -1;
    if (!(v3_len(a->axis) > 0))
        return xml_fail(c, n, "rotation axis must be non-zero");
    a->axis = v3_normalize(a->axis);
    a->has_rotation = 1;
    return 0;
}

/* ---- keyframes -------------------------------------------------------- */


static int key_interpolation(xml_ctx *c, xmlNodePtr n, tangent_kind *in, tangent_kind *out)
{
    char name[64];
    int got = xml_attr_text(c, n, "interpolation", name, sizeof name);
    if (got <= 0)
        return got;
    if (!strcmp(name, "linear")) *in = *out = TAN_LINEAR;
    else if (!strcmp(name, "step")) *in = TAN_FLAT, *out = TAN_STEP;
    else if (!strcmp(name, "spline")) *in = *out = TAN_SPLINE;
    else if (!strcmp(name, "clamped")) *in = *out = TAN_CLAMPED;
    else if (!strcmp(name, "flat")) *in = *out = TAN_FLAT;
    else return xml_fail(c, n, "unknown interpolation '%s' (expected linear, step, spline, clamped or flat)", name);
    return 0;
}

static int append_key(xml_ctx *c, xmlNodePtr n, curve *cv, curve_key k)
{
    int rc = curve_append(cv, &k);
    if (rc == -1)
        return xml_fail(c, n, "key time %g is not after the previous key's %g", k.time,
                         cv->keys[cv->count - 1].time);
    return rc ? xml_fail(c, n, "out of memory") : 0;
}

/* <key time="t" translate="x y z" rotate="degrees x y z" scale="x y z"
 * interpolation="..."/>: each given vector keys its three channels. */
static int parse_key(xml_ctx *c, xmlNodePtr n, keyframes *kf, tangent_kind in, tangent_kind out)
{
    static const char *const ok[] = {"time", "translate", "rotate", "scale", "interpolation", NULL};
    static const char *const vectors[] = {"translate", "rotate", "scale"};
    curve_key k;
    memset(&k, 0, sizeof k);
    if (xml_check_attributes(c, n, ok) || xml_check_no_text(c, n) || xml_attr_double(c, n, "time", &k.time, 1) ||
        key_interpolation(c, n, &in, &out))
        return -1;
    k.in = in, k.out = out;
    int any = 0;
    for (int v = 0; v < 3; v++) {
        vec3 val = v3(0, 0, 0);
        if (!xml_has_attr(n, vectors[v]))
            continue;
        if (xml_attr_vec3(c, n, vectors[v], &val, 1))
            return -1;
        double xyz[3] = {val.x, val.y, val.z};
        for (int i = 0; i < 3; i++) {
            k.value = v == 1 ? xyz[i] * M_PI / 180.0 : xyz[i];
            if (v == 2 && !(xyz[i] > 0))
                return xml_fail(c, n, "scale must be positive");
            if (append_key(c, n, &kf->ch[3 * v + i], k))
                return -1;
        }
        any = 1;
    }
    if (!any)
        return xml_fail(c, n, "a key needs translate, rotate or scale");
    return 0;
}

/* <keyframes interpolation="spline" pivot="x y z" pre="constant"
 * post="constant"> <key .../> ... </keyframes> */
static int parse_keyframes(xml_ctx *c, xmlNodePtr n, keyframes *kf)
{
    static const char *const ok[] = {"interpolation", "pivot", "pre", "post", NULL};
    tangent_kind in = TAN_LINEAR, out = TAN_LINEAR;
    char inf[2][64] = {"constant", "constant"};
    infinity_kind pre, post;
    if (xml_check_attributes(c, n, ok) || xml_attr_text(c, n, "pre", inf[0], sizeof inf[0]) < 0 ||
        xml_attr_text(c, n, "post", inf[1], sizeof inf[1]) < 0 || xml_check_no_text(c, n) ||
        key_interpolation(c, n, &in, &out) || xml_attr_vec3(c, n, "pivot", &kf->pivot, 0))
        return -1;
    if (infinity_from_name(inf[0], &pre) || infinity_from_name(inf[1], &post))
        return xml_fail(c, n, "unknown pre/post infinity (expected constant, linear, cycle, cycleRelative "
                               "or oscillate)");
    int keys = 0;
    for (xmlNodePtr k = n->children; k; k = k->next) {
        if (!xml_is_element(k))
            continue;
        if (strcmp(xml_elname(k), "key"))
            return xml_unknown_element(c, k, "element inside <keyframes>", (const char *const[]){"key", NULL});
        if (parse_key(c, k, kf, in, out))
            return -1;
        keys++;
    }
    if (!keys)
        return xml_fail(c, n, "<keyframes> needs at least one <key>");
    for (int i = 0; i < CH_COUNT; i++) {
        rr_error sub;
        kf->ch[i].pre = pre, kf->ch[i].post = post;
        kf->ch[i].clamp_flat = keyframes_clamp_flat(i);
        if (kf->ch[i].count && curve_prepare(&kf->ch[i], &sub))
            return xml_fail(c, n, "%s", sub.msg);
    }
    return 0;
}

/* Keyframes rotate and scale about a pivot that defaults to the object's
 * position (the camera's position): keyed rotations turn it in place. */
static int new_keyframes(xml_ctx *c, xmlNodePtr n, animation *a)
{
    if (a->keys || a->has_rotation || v3_len(a->velocity) > 0)
        return xml_fail(c, n, "an animation is either keyframes (or a .anim file) or linear/rotation, once");
    a->keys = calloc(1, sizeof *a->keys);
    if (!a->keys)
        return xml_fail(c, n, "out of memory");
    a->keys->pivot = a->offset;
    return 0;
}

/* <animation>path.anim</animation> as in thesis Figure 4.11, or
 * <animation file="path.anim" node="NAME"/> for a file of several nodes. */
static int load_anim_file(xml_ctx *c, xmlNodePtr n, animation *a)
{
    char rel[4096], path[8192], node[ANIMFILE_MAX_WORD + 1]; /* any node an .anim file can name */
    int has_file = xml_attr_text(c, n, "file", rel, sizeof rel);
    int has_node = has_file < 0 ? -1 : xml_attr_text(c, n, "node", node, sizeof node);
    if (has_file < 0 || has_node < 0)
        return -1;
    if (has_file && xml_has_text(n))
        return xml_fail(c, n, "give the .anim path as the 'file' attribute or as the text, not both");
    int has_text = has_file ? 0 : xml_element_text(c, n, rel, sizeof rel);
    if (has_text < 0)
        return -1;
    if (!has_file && !has_text)
        return xml_fail(c, n, "animation file path is empty");
    if (xml_resolve_path(c, n, rel, path, sizeof path) || new_keyframes(c, n, a))
        return -1;
    vec3 pivot = a->keys->pivot;
    free(a->keys);
    a->keys = NULL;
    rr_error sub;
    if (animfile_load(path, has_node ? node : NULL, &a->keys, c->inputs_hash, &c->sc->warnings, &sub))
        return rr_fail(c->err, "%s (animation of %s:%ld)", sub.msg, c->name, xmlGetLineNo(n));
    if (scene_add_input(c->sc, path))
        return xml_fail(c, n, "out of memory");
    a->keys->pivot = pivot;
    return 0;
}

int xml_parse_animation(xml_ctx *c, xmlNodePtr n, animation *a)
{
    static const char *const ok[] = {"file", "node", NULL};
    if (xml_check_attributes(c, n, ok))
        return -1;
    if (xml_has_text(n) || xml_has_attr(n, "file"))
        return load_anim_file(c, n, a);
    if (xml_has_attr(n, "node"))
        return xml_fail(c, n, "'node' selects a node of an .anim file: give the file too");
    for (xmlNodePtr k = n->children; k; k = k->next) {
        if (!xml_is_element(k))
            continue;
        int rc;
        if (!strcmp(xml_elname(k), "linear"))
            rc = a->keys ? new_keyframes(c, k, a) : parse_linear(c, k, a);
        else if (!strcmp(xml_elname(k), "rotation"))
            rc = a->keys ? new_keyframes(c, k, a) : parse_rotation(c, k, a);
        else if (!strcmp(xml_elname(k), "keyframes"))
            rc = new_keyframes(c, k, a) || parse_keyframes(c, k, a->keys);
        else
            rc = xml_unknown_element(c, k, "animation element",
                                     (const char *const[]){"linear", "rotation", "keyframes", NULL});
        if (rc)
            return -1;
    }
    return 0;
}
