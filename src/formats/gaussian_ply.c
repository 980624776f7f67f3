/* Gaussian-splat models' PLY files (gaussian_ply.h): the official layout
 * read through the PLY reader's generic layer (ply.h) and written back. */
#include "formats/gaussian_ply.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/atomicfile.h"
#include "formats/gaussian_dynamic_ply.h"
#include "formats/gaussian_ply_common.h"

/* ---- the PLY layout --------------------------------------------------- */

enum { G_X = 0, G_NX = 3, G_DC = 6, G_REST = 9, G_OPACITY = 54, G_SCALE = 55, G_ROT = 58, G_RGB = 62, G_SLOTS = 65 };
static const char *const slot_names[G_SLOTS] = {
    "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
    "f_rest_0", "f_rest_1", "f_rest_2", "f_rest_3", "f_rest_4", "f_rest_5", "f_rest_6", "f_rest_7", "f_rest_8", "f_rest_9", "f_rest_10", "f_rest_11", "f_rest_12", "f_rest_13", "f_rest_14", "f_rest_15", "f_rest_16", "f_rest_17", "f_rest_18", "f_rest_19", "f_rest_20", "f_rest_21", "f_rest_22", "f_rest_23", "f_rest_24", "f_rest_25", "f_rest_26", "f_rest_27", "f_rest_28", "f_rest_29", "f_rest_30", "f_rest_31", "f_rest_32", "f_rest_33", "f_rest_34", "f_rest_35", "f_rest_36", "f_rest_37", "f_rest_38", "f_rest_39", "f_rest_40", "f_rest_41", "f_rest_42", "f_rest_43", "f_rest_44",
    "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "red", "green", "blue"};
/* red/green/blue as nerfstudio's `ns-export gaussian-splat --ply-color-mode rgb` writes them: uchar,
 * read as u / 255 (integers from G_RGB on divide by their type's maximum). */
static const ply_schema gaussian_schema = {slot_names, G_SLOTS, G_RGB};
/* spherical harmonics' Y_0^0 (nerfstudio splatfacto.py's C0, v1.1.5 6b60855, lines 99 and 107) */
static const double SH_C0 = 0.28209479177387814;

typedef struct {
    gaussian_ply_sink base; /* first: the shared callbacks take it */
    /* every f_rest_<k> the header declares, schema slot or not: those past
     * f_rest_44 have no slot, yet they decide the SH degree (a file of
     * degree 4 must be refused, not read as degree 3) */
    int rest_names, rest_max;
    unsigned char rest_seen[PLY_MAX_PROPERTIES];
    const gaussian_dynamic_ply_reader *dynamic; /* the reader of a dynamic layout's property declared */
    int rgb_colour; /* colour from red/green/blue (no f_dc_*): nerfstudio's RGB export */
} gaussian_sink;

static int require(const char *path, const int *present, int first, int n, rr_error *err)
{
    for (int s = first; s < first + n; s++)
        if (!present[s])
            return rr_fail(err, "%s: Gaussian model lacks the vertex property '%s'", path, slot_names[s]);
    return 0;
}

/* k of a property named f_rest_<k> (decimal digits), else -1. */
static int rest_index(const char *name)
{
    long k = gaussian_ply_numbered(name, "f_rest_");
    return k > 1000000 ? -1 : (int)k;
}

/* The header's vertex properties as declared: counts every f_rest_<k>
 * (the schema holds only degree 3's 45), and refuses Mip-Splatting's
 * filter_3D (its 3D smoothing filter changes every Gaussian's extent and
 * opacity, so ignoring it would render another model). */
static int see_property(void *user, const char *path, long line, const char *name, rr_error *err)
{
    gaussian_sink *s = user;
    if ((s->dynamic = gaussian_dynamic_ply_claimant(name))) /* read by that reader instead */
        return rr_fail(err, "%s:%ld: %s property '%s'", path, line, s->dynamic->layout, name);
    if (!strcmp(name, "filter_3D"))
        return rr_fail(err, "%s:%ld: vertex property 'filter_3D': Mip-Splatting's 3D filter is not supported (the "
                            "model would render without it)", path, line);
    int k = rest_index(name);
    if (k < 0)
        return 0;
    if (k < PLY_MAX_PROPERTIES && s->rest_seen[k]) /* slots below 45 were refused as duplicates already */
        return rr_fail(err, "%s:%ld: duplicate vertex property '%s'", path, line, name);
    if (k < PLY_MAX_PROPERTIES)
        s->rest_seen[k] = 1;
    s->rest_names++;
    s->rest_max = k > s->rest_max ? k : s->rest_max;
    return 0;
}

/* The SH degree d from the f_rest properties: a contiguous run from
 * f_rest_0 of 3((d + 1)^2 - 1) (0, 9, 24, 45 for degrees 0 to 3); degree 4's
 * 72 and others are refused, naming the degree they would need. */
static int sh_degree_of(const char *path, const gaussian_sink *s, rr_error *err)
{
    int n = s->rest_names;
    if (n && s->rest_max != n - 1) { /* distinct names, so a gap: the first missing and the next present */
        int gap = 0, next;
        while (s->rest_seen[gap])
            gap++;
        for (next = gap + 1; next < PLY_MAX_PROPERTIES && !s->rest_seen[next]; next++)
            ;
        return rr_fail(err, "%s: property 'f_rest_%d' is present but 'f_rest_%d' is not (f_rest_* must run from "
                            "f_rest_0 without gaps)", path, next < PLY_MAX_PROPERTIES ? next : s->rest_max, gap);
    }
    int d = 0;
    while (3 * ((d + 1) * (d + 1) - 1) < n)
        d++;
    int need = 3 * ((d + 1) * (d + 1) - 1), below = 3 * (d * d - 1);
    if (need == n && d <= GAUSSIAN_MAX_SH_DEGREE)
        return d;
    if (need == n)
        return rr_fail(err, "%s: %d f_rest properties make SH degree %d (degree d has 3((d+1)^2-1)): degrees above 3 "
                            "are not supported", path, n, d);
    return rr_fail(err, "%s: %d f_rest properties are no SH degree (degree d has 3((d+1)^2-1): 0, 9, 24 or 45 for "
                        "degrees 0 to 3): %d lies between degree %d's %d and degree %d's %d%s",
                   path, n, n, d - 1, below, d, need, d > GAUSSIAN_MAX_SH_DEGREE ? "; degrees above 3 are not supported" : "");
}

/* Colour from f_dc_* (SH), or, with no f_dc_* at all, from red/green/blue: nerfstudio v1.1.5
 * (6b60855) scripts/exporter.py:588-593 writes those instead of f_dc_* with --ply-color-mode rgb
 * and skips f_rest_* (596-606), so such a file is SH degree 0; f_rest_* beside them is refused. */
static int colour_layout(gaussian_sink *s, const char *path, const int *present, rr_error *err)
{
    int any_dc = present[G_DC] || present[G_DC + 1] || present[G_DC + 2];
    int any_rgb = present[G_RGB] || present[G_RGB + 1] || present[G_RGB + 2];
    s->rgb_colour = !any_dc && any_rgb;
    if (!s->rgb_colour)
        return require(path, present, G_DC, 3, err);
    if (require(path, present, G_RGB, 3, err))
        return -1;
    if (s->rest_names)
        return rr_fail(err, "%s: vertex properties red/green/blue and f_rest_* without f_dc_*: the SH colour's "
                            "f_dc_0..2 are missing (nerfstudio's RGB export writes no f_rest_*)", path);
    return 0;
}

static int begin_model(void *user, const char *path, const int *present, size_t count, rr_error *err)
{
    gaussian_sink *s = user;
    gaussian_model *m = s->base.m;
    if (require(path, present, G_X, 3, err) || colour_layout(s, path, present, err) ||
        require(path, present, G_OPACITY, 1, err) || require(path, present, G_SCALE, 2, err) ||
        require(path, present, G_ROT, 4, err))
        return -1;
    m->kind = s->base.forced ? s->base.forced : present[G_SCALE + 2] ? GAUSSIAN_3D : GAUSSIAN_2D;
    if (m->kind == GAUSSIAN_3D && require(path, present, G_SCALE + 2, 1, err))
        return -1;
    int degree = sh_degree_of(path, s, err);
    if (degree < 0)
        return -1;
    m->sh_degree = degree, m->sh_coeffs = (degree + 1) * (degree + 1);
    s->base.declared = count, s->base.next = 0;
    return 0;
}

static int store(float *dst, double v, int slot, char *why, size_t why_size)
{
    return gaussian_ply_store(dst, v, slot_names[slot], why, why_size);
}

/* Means within RR_MAX_REACH, scales (two for 2D), after exp, within
 * RR_MAX_REACH, the unit quaternion. */
static int store_geometry(gaussian_model *m, size_t i, const double *v, char *why, size_t why_size)
{
    int scales = m->kind == GAUSSIAN_3D ? 3 : 2;
    return gaussian_ply_store_mean_scale(m, i, v, slot_names, G_X, G_SCALE, scales, why, why_size) ||
                   gaussian_ply_unit_quaternion(&v[G_ROT], &m->rotation[4 * i], why, why_size)
               ? -1
               : 0;
}

/* The SH coefficients, rest channel-major in the file. An RGB colour in [0, 1] becomes the DC
 * coefficient nerfstudio's model holds for it: splatfacto.py:335-339 (v1.1.5) draws
 * colors = SH2RGB(features_dc) = C0 dc + 0.5 (line 108) at degree 0, so dc = (rgb - 0.5) / C0
 * (RGB2SH, line 100), which draws the same colour through refrender's SH (C0 dc + 0.5). */
static int store_sh(gaussian_model *m, size_t i, const double *v, int rgb_colour, char *why, size_t why_size)
{
    float *sh = m->sh + 3 * (size_t)m->sh_coeffs * i;
    int rest = m->sh_coeffs - 1;
    if (rgb_colour) {
        for (int c = 0; c < 3; c++)
            if (store(&sh[c], (v[G_RGB + c] - 0.5) / SH_C0, G_RGB + c, why, why_size))
                return -1;
        return 0;
    }
    for (int c = 0; c < 3; c++) {
        if (store(&sh[c], v[G_DC + c], G_DC + c, why, why_size))
            return -1;
        for (int k = 1; k <= rest; k++)
            if (store(&sh[3 * k + c], v[G_REST + c * rest + (k - 1)], G_REST + c * rest + (k - 1), why, why_size))
                return -1;
    }
    return 0;
}

/* The activations of the official loader: exp for scales, sigmoid for
 * opacity, the quaternion normalised (w first). */
static int add_gaussian(void *user, const double *v, const int *present, char *why, size_t why_size)
{
    gaussian_sink *s = user;
    gaussian_model *m = s->base.m;
    if (!m->mean && gaussian_ply_allocate(m, s->base.declared, NULL, why, why_size))
        return -1;
    if (gaussian_ply_check_finite(v, present, slot_names, G_SLOTS, why, why_size))
        return -1;
    size_t i = s->base.next;
    if (store_geometry(m, i, v, why, why_size) || store_sh(m, i, v, s->rgb_colour, why, why_size))
        return -1;
    m->opacity[i] = (float)(1.0 / (1.0 + exp(-v[G_OPACITY]))); /* in [0, 1] for any finite value */
    m->count = ++s->base.next;
    return 0;
}

/* Parses len bytes at data, or the opened file src (not NULL). A dynamic
 * model's layout is seen in the header, before the parse has released any
 * of the file: its own reader then parses the same bytes, so the file is
 * read and hashed once (it was read twice, the failed static pass hashing
 * every byte it had not parsed). */
static int load(const char *name, const char *data, size_t len, input_file *src, gaussian_kind kind,
                gaussian_model *m, rr_error *err)
{
    gaussian_model_free(m);
    gaussian_sink *sink = calloc(1, sizeof *sink);
    if (!sink)
        return rr_fail(err, "%s: out of memory", name);
    sink->base.m = m, sink->base.forced = kind;
    ply_visitor v = {begin_model, add_gaussian, sink, see_property};
    int rc = src ? ply_stream_vertices(name, src, &gaussian_schema, &v, err)
                 : ply_parse_vertices(name, data, len, &gaussian_schema, &v, err);
    const gaussian_dynamic_ply_reader *dynamic = sink->dynamic;
    free(sink);
    RR_CHECK(!dynamic || !src || src->released == 0); /* refused in the header: nothing released */
    return dynamic ? dynamic->load(name, data, len, src, kind, m, err) : gaussian_ply_finish(m, rc, name, err);
}

int gaussian_parse(const char *name, const char *data, size_t len, gaussian_kind kind, gaussian_model *m,
                   rr_error *err)
{
    return load(name, data ? data : "", len, NULL, kind, m, err);
}

int gaussian_read(const char *path, gaussian_kind kind, gaussian_model *m, uint64_t *content_hash,
                  volatile sig_atomic_t *cancel, rr_error *err)
{
    input_file in;
    if (input_file_stream(path, PLY_MAX_BYTES, &in, err))
        return -1;
    in.hash = content_hash ? *content_hash : INPUT_HASH_INIT;
    in.cancel = cancel; /* every layout's parse reads the file through ply_stream_vertices */
    int rc = load(path, in.data, in.len, &in, kind, m, err);
    if (content_hash)
        *content_hash = input_file_hash(&in);
    input_file_free(&in);
    return rc;
}

/* ---- writing ------------------------------------------------------------ */

static int put_f32(FILE *f, double v)
{
    float x = (float)v;
    return fwrite(&x, 4, 1, f) == 1; /* little endian hosts only: checked in gaussian_write_ply */
}

static void write_header(FILE *f, const gaussian_model *m)
{
    int rest = 3 * (m->sh_coeffs - 1), scales = m->kind == GAUSSIAN_3D ? 3 : 2;
    fprintf(f, "ply\nformat binary_little_endian 1.0\ncomment written by refrender %s (%s)\nelement vertex %zu\n",
            RR_VERSION, m->kind == GAUSSIAN_3D ? "3DGS" : "2DGS", m->count);
    for (int k = 0; k < G_REST; k++)
        fprintf(f, "property float %s\n", slot_names[k]);
    for (int k = 0; k < rest; k++)
        fprintf(f, "property float %s\n", slot_names[G_REST + k]);
    for (int k = G_OPACITY; k < G_SCALE + scales; k++)
        fprintf(f, "property float %s\n", slot_names[k]);
    for (int k = G_ROT; k < G_RGB; k++)
        fprintf(f, "property float %s\n", slot_names[k]);
    fputs("end_header\n", f);
}

/* One Gaussian as the official save_ply stores it: the activations undone
 * (logit of the opacity, log of the scales), rest coefficients
 * channel-major, normals zero. */
static int write_gaussian(FILE *f, const gaussian_model *m, size_t i)
{
    int ok = 1, rest = m->sh_coeffs - 1, scales = m->kind == GAUSSIAN_3D ? 3 : 2;
    const float *sh = m->sh + 3 * (size_t)m->sh_coeffs * i;
    for (int k = 0; k < 3; k++)
        ok &= put_f32(f, m->mean[3 * i + k]);
    for (int k = 0; k < 3; k++)
        ok &= put_f32(f, 0.0);
    for (int c = 0; c < 3; c++)
        ok &= put_f32(f, sh[c]);
    for (int c = 0; c < 3; c++)
        for (int k = 1; k <= rest; k++)
            ok &= put_f32(f, sh[3 * k + c]);
    double o = m->opacity[i];
    ok &= put_f32(f, log(o / (1.0 - o)));
    for (int k = 0; k < scales; k++)
        ok &= put_f32(f, log(m->scale[3 * i + k]));
    for (int k = 0; k < 4; k++)
        ok &= put_f32(f, m->rotation[4 * i + k]);
    return ok;
}

typedef struct {
    const char *path;
    const gaussian_model *m;
} model_file;

static int write_model(FILE *f, void *ctx, rr_error *err)
{
    const model_file *mf = ctx;
    write_header(f, mf->m);
    int ok = 1;
    for (size_t i = 0; i < mf->m->count && ok; i++)
        ok = write_gaussian(f, mf->m, i);
    return ok && !ferror(f) ? 0 : rr_fail(err, "%s: write failed (disk full?)", mf->path);
}

int gaussian_write_ply(const char *path, const gaussian_model *m, rr_error *err)
{
    const uint16_t one = 1;
    if (*(const uint8_t *)&one != 1)
        return rr_fail(err, "%s: writing Gaussian PLYs needs a little-endian host", path);
    if (m->dynamic) /* the official layout has no motion: it would be dropped */
        return rr_fail(err, "%s: writing SpacetimeGaussians models is not supported", path);
    for (size_t i = 0; i < m->count; i++) /* what would not read back is not written */
        if (!(m->opacity[i] > 0 && m->opacity[i] < 1) || !(m->scale[3 * i] > 0 && m->scale[3 * i + 1] > 0))
            return rr_fail(err, "%s: Gaussian %zu has an opacity outside (0, 1) or a zero scale", path, i);
    model_file mf = {path, m};
    return atomic_write_stdio(path, write_model, &mf, err);
}

