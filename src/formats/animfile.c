#include "formats/animfile.h"

#include <ctype.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/inputfile.h"

/* ---- tokens: words, ';', '{', '}'; comments // and # to end of line ------- */

/* A word (number, node or attribute name) longer than ANIMFILE_MAX_WORD
 * is refused, naming its line and length: words were once cut at 63
 * characters, so a 69-character number read as another value and two long
 * node names as one. */
#define ANIM_WORD (ANIMFILE_MAX_WORD + 1)

typedef struct {
    const char *p;
    int line;
    const char *name;
    rr_error *err;
    rr_warnings *warnings; /* returned to the caller, never printed here */
    char tok[ANIM_WORD];
    size_t tok_len; /* the word's full length: more than fits in tok means it is too long */
    int tok_line;
} lexer;

static void skip_space(lexer *lx)
{
    for (;;) {
        while (*lx->p && isspace((unsigned char)*lx->p)) {
            lx->line += *lx->p == '\n';
            lx->p++;
        }
        if (*lx->p == '#' || (lx->p[0] == '/' && lx->p[1] == '/')) {
            while (*lx->p && *lx->p != '\n')
                lx->p++;
            continue;
        }
        return;
    }
}

/* Next token into lx->tok; 0 at the end of the text. */
static int next(lexer *lx)
{
    skip_space(lx);
    lx->tok_line = lx->line;
    if (!*lx->p) {
        lx->tok[0] = 0;
        return 0;
    }
    size_t n = 0;
    if (strchr(";{}", *lx->p)) {
        lx->tok[n++] = *lx->p++;
    } else {
        for (; *lx->p && !isspace((unsigned char)*lx->p) && !strchr(";{}", *lx->p); lx->p++, n++)
            if (n + 1 < sizeof lx->tok)
                lx->tok[n] = *lx->p;
    }
    lx->tok_len = n;
    lx->tok[n < sizeof lx->tok ? n : sizeof lx->tok - 1] = 0;
    return 1;
}

static int fail(lexer *lx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* At the end of the text inside a block: a truncated file. */
static int truncated(lexer *lx, const char *block)
{
    skip_space(lx);
    if (*lx->p)
        return 0;
    lx->tok_line = lx->line;
    return fail(lx, "file ends inside the %s block (truncated? missing '}')", block), 1;
}

static int peek_is(lexer *lx, const char *word)
{
    lexer copy = *lx;
    return next(&copy) && !strcmp(copy.tok, word);
}

static int fail(lexer *lx, const char *fmt, ...)
{
    char msg[sizeof lx->err->msg]; /* room for a whole word (ANIMFILE_MAX_WORD) quoted in the message */
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return rr_fail(lx->err, "%s:%d: %s", lx->name, lx->tok_line, msg);
}

static int expect(lexer *lx, const char *what)
{
    if (!next(lx))
        return fail(lx, "file ends where '%s' was expected (truncated?)", what);
    if (strcmp(lx->tok, what))
        return fail(lx, "expected '%s', found '%s'", what, lx->tok);
    return 0;
}

/* Reads the words of one statement up to ';' (at most max). */
static int statement(lexer *lx, char words[][ANIM_WORD], int max, int *count)
{
    *count = 0;
    for (;;) {
        if (!next(lx))
            return fail(lx, "file ends inside a statement (missing ';')");
        if (!strcmp(lx->tok, ";"))
            return 0;
        if (!strcmp(lx->tok, "{") || !strcmp(lx->tok, "}"))
            return fail(lx, "unexpected '%s' (missing ';' on the line before?)", lx->tok);
        if (*count == max)
            return fail(lx, "too many fields in this statement");
        if (lx->tok_len >= ANIM_WORD)
            return fail(lx, "a word of %zu characters ('%.20s...'): at most %d are read", lx->tok_len, lx->tok,
                        ANIM_WORD - 1);
        memcpy(words[(*count)++], lx->tok, lx->tok_len + 1);
    }
}

static int number(lexer *lx, const char *word, double *v)
{
    char *end;
    *v = strtod(word, &end);
    if (end == word || *end)
        return fail(lx, "'%s' is not a number", word);
    if (!isfinite(*v))
        return fail(lx, "'%s' is not a finite number", word);
    return 0;
}

/* ---- units ----------------------------------------------------------------- */

typedef struct {
    double seconds_per_frame, meters_per_unit, radians_per_unit;
    double version;
    int maya2; /* written by Maya 2.x: tangents in seconds and internal units */
} units;

static int time_unit(const char *u, double *spf)
{
    static const struct {
        const char *name;
        double seconds;
    } t[] = {{"film", 1.0 / 24}, {"ntsc", 1.0 / 30}, {"pal", 1.0 / 25}, {"game", 1.0 / 15},
             {"show", 1.0 / 48}, {"palf", 1.0 / 50}, {"ntscf", 1.0 / 60}, {"sec", 1},
             {"millisec", 1e-3}, {"min", 60}, {"hour", 3600}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        if (!strcmp(u, t[i].name))
            return *spf = t[i].seconds, 0;
    return -1;
}

static int linear_unit(const char *u, double *m)
{
    static const struct {
        const char *name;
        double meters;
    } t[] = {{"mm", 1e-3}, {"cm", 1e-2}, {"m", 1}, {"km", 1e3},
             {"in", 0.0254}, {"ft", 0.3048}, {"yd", 0.9144}, {"mi", 1609.344}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        if (!strcmp(u, t[i].name))
            return *m = t[i].meters, 0;
    return -1;
}

static int angular_unit(const char *u, double *r)
{
    if (!strcmp(u, "deg")) return *r = M_PI / 180, 0;
    if (!strcmp(u, "rad")) return *r = 1, 0;
    if (!strcmp(u, "min")) return *r = M_PI / (180 * 60), 0;
    if (!strcmp(u, "sec")) return *r = M_PI / (180 * 3600), 0;
    return -1;
}

/* ---- one curve ------------------------------------------------------------- */

static int channel_of(const char *leaf)
{
    static const char *const longs[] = {"translateX", "translateY", "translateZ", "rotateX", "rotateY",
                                        "rotateZ", "scaleX", "scaleY", "scaleZ"};
    static const char *const shorts[] = {"tx", "ty", "tz", "rx", "ry", "rz", "sx", "sy", "sz"};
    for (int i = 0; i < CH_COUNT; i++)
        if (!strcmp(leaf, longs[i]) || !strcmp(leaf, shorts[i]))
            return i;
    return -1;
}

typedef struct {
    curve *c;
    int channel;      /* < 0: read and skip (-1 unsupported attribute, -2 another node) */
    double value_scale, seconds_per_frame;
    double tangent_radians; /* radians per unit of the tangent angles (tangentAngleUnit) */
    int weighted;
} curve_reader;

static int add_key(lexer *lx, curve_reader *r, const curve_key *k)
{
    const curve *c = r->c;
    int rc = curve_append(r->c, k);
    if (rc == -1)
        return fail(lx, "key time %g is not after the previous key's %g (key times must increase)",
                    k->time / r->seconds_per_frame, c->keys[c->count - 1].time / r->seconds_per_frame);
    return rc ? fail(lx, "out of memory") : 0;
}

/* A fixed tangent's angle and weight fields, to an angle of the same slope
 * in scene units and the time its Bezier handle reaches on a weighted
 * curve.
 *
 * Both are measured in one plane. Maya writes them in the file's own
 * units, per frame of its timeUnit (checked on Maya 2026 exports: the
 * tangent of a fixed key equals the per-frame secant to seven digits;
 * Autodesk's animImportExport reader sets the UI units to the file's before
 * reading them). Maya 2.x wrote them per second in its internal units
 * (centimeters, radians), which that reader converts.
 *
 * The weight is the handle's length in that plane, so it reaches
 * weight cos(angle) along time: Autodesk's animEngine builds the tangent as
 * 3 weight (cos, sin)(angle) with frames over the frame rate (seconds),
 * animx puts the control point a third of the tangent from the key, and the
 * animImportExport reader converts Maya 2.x weights between unit systems as
 * lengths in that plane. */
static int fixed_tangent(lexer *lx, const curve_reader *r, const units *u, char key[][ANIM_WORD], int at, int out,
                         curve_key *k)
{
    double a, weight;
    const char *side = out ? "out" : "in";
    if (number(lx, key[at], &a) || number(lx, key[at + 1], &weight))
        return -1;
    if (!(weight >= 0))
        return fail(lx, "key at time %s: %s-tangent weight %s is negative", key[0], side, key[at + 1]);
    double seconds = u->maya2 ? 1.0 : r->seconds_per_frame; /* scene units per unit of the plane's axes */
    double values = !u->maya2 ? r->value_scale : r->channel >= CH_TX && r->channel <= CH_TZ ? 0.01 : 1.0;
    a *= r->tangent_radians;
    if (!(cos(a) > 0)) /* its handle would run backwards in time (it was reported as a negative weight) */
        return fail(lx, "key at time %s: %s-tangent angle %s points backwards in time or straight up (Maya's "
                        "tangent angles lie strictly between -90 and 90 degrees)", key[0], side, key[at]);
    *(out ? &k->out_angle : &k->in_angle) = atan(tan(a) * values / seconds);
    *(out ? &k->out_handle : &k->in_handle) = weight * cos(a) * seconds;
    return 0;
}

static int tangent(lexer *lx, const char *name, tangent_kind *k)
{
    if (tangent_from_name(name, k))
        return fail(lx, "unknown or unsupported tangent type '%s' (expected linear, step, stepnext, flat, "
                        "spline, clamped, plateau, auto, fixed, slow or fast)", name);
    return 0;
}

/* time value in out tanLocked weightLocked [breakdown] [inAngle inWeight]
 * [outAngle outWeight] */
static int parse_key(lexer *lx, curve_reader *r, char w[][ANIM_WORD], int n, const units *u)
{
    curve_key k;
    memset(&k, 0, sizeof k);
    if (n < 4)
        return fail(lx, "a key needs at least time, value and two tangent types, got %d fields", n);
    if (number(lx, w[0], &k.time) || number(lx, w[1], &k.value) || tangent(lx, w[2], &k.in) ||
        tangent(lx, w[3], &k.out))
        return -1;
    int base = u->version >= 1.1 ? 7 : 6;
    int extra = 2 * (k.in == TAN_FIXED) + 2 * (k.out == TAN_FIXED);
    if (n == base - 1 + extra && base == 7)
        base = 6; /* tolerate a 1.1 file written without breakdown flags */
    if (n != base + extra)
        return fail(lx, "a key with tangents %s/%s has %d fields, expected %d", w[2], w[3], n, base + extra);
    int in = k.in == TAN_FIXED; /* the in-tangent's fields come first */
    if ((in && fixed_tangent(lx, r, u, w, base, 0, &k)) ||
        (k.out == TAN_FIXED && fixed_tangent(lx, r, u, w, base + 2 * in, 1, &k)))
        return -1;
    k.time *= r->seconds_per_frame;
    k.value *= r->value_scale;
    return add_key(lx, r, &k);
}

static int parse_keys(lexer *lx, curve_reader *r, const units *u)
{
    if (expect(lx, "{"))
        return -1;
    char w[16][ANIM_WORD];
    for (;;) {
        if (truncated(lx, "keys"))
            return -1;
        if (peek_is(lx, "}"))
            return next(lx), 0;
        int n;
        if (statement(lx, w, 16, &n) || parse_key(lx, r, w, n, u))
            return -1;
    }
}

static int infinity(lexer *lx, const char *name, infinity_kind *k)
{
    if (infinity_from_name(name, k))
        return fail(lx, "unknown infinity '%s' (expected constant, linear, cycle, cycleRelative or oscillate)", name);
    return 0;
}

/* One statement of animData: input, output, weighted, units, infinities. */
static int anim_data_statement(lexer *lx, curve_reader *r, char w[][ANIM_WORD], int n)
{
    if (n != 2)
        return fail(lx, "'%s' takes one value", w[0]);
    const char *key = w[0], *val = w[1];
    if (!strcmp(key, "input")) {
        if (strcmp(val, "time"))
            return fail(lx, "input '%s' is not supported (only time-driven curves)", val);
    } else if (!strcmp(key, "weighted")) {
        r->weighted = strcmp(val, "0") != 0;
    } else if (!strcmp(key, "preInfinity")) {
        return infinity(lx, val, &r->c->pre);
    } else if (!strcmp(key, "postInfinity")) {
        return infinity(lx, val, &r->c->post);
    } else if (!strcmp(key, "inputUnit")) {
        if (time_unit(val, &r->seconds_per_frame))
            return fail(lx, "unknown time unit '%s'", val);
    } else if (!strcmp(key, "tangentAngleUnit")) {
        if (angular_unit(val, &r->tangent_radians))
            return fail(lx, "unknown tangent angle unit '%s'", val);
    } else if (!strcmp(key, "outputUnit") && r->channel >= 0 && r->channel < CH_SX) {
        double f;
        if (r->channel >= CH_RX && r->channel <= CH_RZ ? angular_unit(val, &f) : linear_unit(val, &f))
            return fail(lx, "unknown output unit '%s' for this curve", val);
        r->value_scale = f;
    } /* output and others: nothing to do */
    return 0;
}

static int parse_anim_data(lexer *lx, curve_reader *r, const units *u)
{
    if (expect(lx, "animData") || expect(lx, "{"))
        return -1;
    char w[16][ANIM_WORD];
    for (;;) {
        if (truncated(lx, "animData"))
            return -1;
        if (peek_is(lx, "}"))
            return next(lx), 0;
        if (peek_is(lx, "keys")) {
            next(lx);
            if (parse_keys(lx, r, u))
                return -1;
            continue;
        }
        int n;
        if (statement(lx, w, 16, &n) || (n > 0 && anim_data_statement(lx, r, w, n)))
            return -1;
    }
}

/* ---- the file ---------------------------------------------------------- */

static int header_statement(lexer *lx, char w[][ANIM_WORD], int n, units *u)
{
    const char *key = w[0];
    if (n < 2)
        return 0;
    if (!strcmp(key, "animVersion"))
        return number(lx, w[1], &u->version);
    if (!strcmp(key, "mayaVersion")) /* "2.5", not "2026" */
        u->maya2 = !strncmp(w[1], "2.", 2);
    if (!strcmp(key, "timeUnit") && time_unit(w[1], &u->seconds_per_frame))
        return fail(lx, "unknown timeUnit '%s'", w[1]);
    if (!strcmp(key, "linearUnit") && linear_unit(w[1], &u->meters_per_unit))
        return fail(lx, "unknown linearUnit '%s'", w[1]);
    if (!strcmp(key, "angularUnit") && angular_unit(w[1], &u->radians_per_unit))
        return fail(lx, "unknown angularUnit '%s'", w[1]);
    return 0; /* mayaVersion, startTime, endTime, ...: informational */
}

/* Maya exports a visibility curve with the transforms. refrender draws every
 * object at every time, so a curve that holds 1 (visible) throughout changes
 * nothing and is skipped without a word; any other would hide the object
 * somewhere, which refrender cannot do, and is warned about like every
 * unsupported curve. Constant 1: every key is 1, and the curve neither
 * slopes (its slope bound is 0) nor jumps. */
static int always_visible(const char *leaf, curve *c)
{
    rr_error sub;
    if (strcmp(leaf, "visibility") || c->count == 0 || curve_prepare(c, &sub))
        return 0;
    for (int i = 0; i < c->count; i++)
        if (c->keys[i].value != 1.0)
            return 0;
    return curve_max_slope(c) == 0.0 && curve_is_continuous(c);
}

/* anim <attribute path> [<leaf> <node> <row> <child> <index>]; [animData {...}] */
static int parse_anim(lexer *lx, keyframes *kf, char w[][ANIM_WORD], int n, const units *u, int *seen, int selected)
{
    int line = lx->tok_line;
    if (n < 2)
        return fail(lx, "'anim' needs an attribute name");
    const char *dot = strrchr(w[1], '.');
    const char *leaf = dot ? dot + 1 : w[1];
    if (!peek_is(lx, "animData"))
        return 0; /* an attribute listed without a curve */
    int ch = selected ? channel_of(leaf) : -2; /* -2: another node's curve, read and dropped */
    curve skipped = {0, NULL, INF_CONSTANT, INF_CONSTANT, 0, 0.0, 0.0};
    curve_reader r = {ch >= 0 ? &kf->ch[ch] : &skipped, ch, 1.0, u->seconds_per_frame, u->radians_per_unit, 0};
    if (ch >= 0 && seen[ch])
        return rr_fail(lx->err, "%s:%d: a second curve for '%s' (first at line %d)", lx->name, line, leaf, seen[ch]);
    else if (ch >= 0)
        seen[ch] = line;
    r.value_scale = ch >= 0 && ch <= CH_TZ ? u->meters_per_unit : ch >= CH_RX && ch <= CH_RZ ? u->radians_per_unit : 1.0;
    int rc = parse_anim_data(lx, &r, u);
    r.c->weighted = r.weighted;
    if (!rc && ch == -1 && !always_visible(leaf, &skipped))
        rr_warn(lx->warnings, "%s:%d: skipping curve of unsupported attribute '%s'", lx->name, line, w[1]);
    curve_free(&skipped);
    if (rc)
        return -1;
    rr_error sub;
    r.c->clamp_flat = ch >= 0 ? keyframes_clamp_flat(ch) : 0.0;
    if (ch >= 0 && curve_prepare(r.c, &sub))
        return rr_fail(lx->err, "%s:%d: curve '%s': %s", lx->name, line, leaf, sub.msg);
    if (ch >= CH_SX)
        for (int i = 0; i < r.c->count; i++)
            if (!(r.c->keys[i].value > 0))
                return rr_fail(lx->err, "%s:%d: curve '%s': scale keys must be positive", lx->name, line, leaf);
    return 0;
}

/* The distinct nodes that 'anim' statements name (the 4th word: "anim
 * translate.translateX translateX joint2 0 1 0;"). */
typedef struct {
    int count;
    size_t cap;
    char **names; /* grows: a rig of any size (256 nodes were once the most recorded) */
    int failed;   /* out of memory */
} node_list;

static void node_list_free(node_list *nodes)
{
    for (int i = 0; i < nodes->count; i++)
        free(nodes->names[i]);
    free(nodes->names);
}

static void node_list_add(node_list *nodes, const char *name)
{
    if (rr_grow((void **)&nodes->names, &nodes->cap, (size_t)nodes->count + 1, sizeof *nodes->names)) {
        nodes->failed = 1;
        return;
    }
    if (!(nodes->names[nodes->count] = strdup(name)))
        nodes->failed = 1;
    else
        nodes->count++;
}

/* Records the node of a statement that carries a curve; returns whether
 * it is the wanted node's (node NULL: the first node named in the file).
 * Autodesk's animImportExport reader: "anim <attribute> <leaf> <node> row
 * child attr;" names the node; without the leaf and node words (an export
 * without node names) there is none. */
static int select_node(node_list *nodes, char w[][ANIM_WORD], int n, const char *node)
{
    const char *here = n >= 7 ? w[3] : "";
    int known = 0;
    for (int i = 0; i < nodes->count && !known; i++)
        known = !strcmp(nodes->names[i], here);
    if (!known)
        node_list_add(nodes, here);
    return nodes->count > 0 && !strcmp(here, node ? node : nodes->names[0]);
}

/* The node names for a message, as many as fit, then how many more: the
 * list was cut off mid-name without a word. */
static void list_nodes(const node_list *nodes, char *buf, size_t size)
{
    size_t len = 0;
    int i = 0;
    buf[0] = 0;
    for (; i < nodes->count; i++) {
        int w = snprintf(buf + len, size - len, "%s'%s'", i ? ", " : "", nodes->names[i]);
        if (w < 0 || (size_t)w + 32 >= size - len) /* keep room for the count */
            break;
        len += (size_t)w;
    }
    if (i < nodes->count)
        snprintf(buf + len, size - len, "%s and %d more", i ? "," : "", nodes->count - i);
}

/* With several nodes in the file a node must be named, and a named node
 * must be there. */
static int check_node_choice(const node_list *nodes, const char *name, const char *node, rr_error *err)
{
    char names[512]; /* with the rest of the message, within an rr_error */
    list_nodes(nodes, names, sizeof names);
    if (!node && nodes->count > 1)
        return rr_fail(err, "%s: the file animates %d nodes (%s): choose one with <animation file=\"...\" "
                            "node=\"NAME\"/>", name, nodes->count, names);
    for (int i = 0; node && i < nodes->count; i++)
        if (!strcmp(nodes->names[i], node))
            return 0;
    return node ? rr_fail(err, "%s: no curves for node '%s'; the file animates %s", name, node, names) : 0;
}

int animfile_parse(const char *text, const char *name, const char *node, keyframes **out, rr_warnings *warnings,
                   rr_error *err)
{
    keyframes *kf = calloc(1, sizeof *kf);
    if (!kf)
        return rr_fail(err, "out of memory");
    lexer lx = {text, 1, name, err, warnings, {0}, 0, 1};
    units u = {1.0 / 24, 0.01, M_PI / 180, 1.1, 0}; /* Maya's defaults: film, cm, deg */
    int seen[CH_COUNT] = {0}, curves = 0, versioned = 0;
    node_list nodes = {0, 0, NULL, 0};
    char w[16][ANIM_WORD];
    while (skip_space(&lx), *lx.p) {
        int n;
        if (statement(&lx, w, 16, &n))
            goto fail;
        if (n == 0)
            continue;
        versioned |= !strcmp(w[0], "animVersion");
        if (!versioned) {
            rr_fail(err, "%s:%d: not a Maya .anim file (it must start with 'animVersion')", name, lx.tok_line);
            goto fail;
        }
        if (!strcmp(w[0], "anim")) {
            /* without animData: a node or attribute listed as a placeholder */
            int with_curve = peek_is(&lx, "animData");
            if (parse_anim(&lx, kf, w, n, &u, seen, with_curve && select_node(&nodes, w, n, node)))
                goto fail;
            if (nodes.failed) {
                rr_fail(err, "%s: out of memory for node names", name);
                goto fail;
            }
            curves += with_curve;
        } else if (header_statement(&lx, w, n, &u)) {
            goto fail;
        }
    }
    if (!versioned) {
        rr_fail(err, "%s:1: empty file: not a Maya .anim file", name);
        goto fail;
    }
    if (check_node_choice(&nodes, name, node, err))
        goto fail;
    int used = 0;
    for (int i = 0; i < CH_COUNT; i++)
        used += seen[i] != 0;
    if (!used) {
        rr_fail(err, "%s: no translate, rotate or scale curve found (%d curves read)", name, curves);
        goto fail;
    }
    node_list_free(&nodes);
    *out = kf;
    return 0;
fail:
    node_list_free(&nodes);
    for (int i = 0; i < CH_COUNT; i++)
        curve_free(&kf->ch[i]);
    free(kf);
    return -1;
}

int animfile_load(const char *path, const char *node, keyframes **out, uint64_t *content_hash, rr_warnings *warnings,
                  rr_error *err)
{
    input_file in;
    if (input_file_read(path, ANIMFILE_MAX_BYTES, &in, err))
        return -1;
    if (content_hash)
        *content_hash = input_hash(*content_hash, in.data, in.len);
    int rc = strlen(in.data) != in.len ? rr_fail(err, "%s: binary data in a text .anim file", path)
                                       : animfile_parse(in.data, path, node, out, warnings, err);
    input_file_free(&in);
    return rc;
}
