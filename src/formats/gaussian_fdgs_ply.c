/* 4DGS models' PLY (gaussian_dynamic_ply.h): scripts/convert_4dgs.py's
 * layout read through the PLY reader's generic layer (ply.h). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "formats/gaussian_dynamic_ply.h"
#include "formats/gaussian_ply_common.h"
#include "gaussians/gaussian_fdgs.h"

/* ---- the layout (scripts/convert_4dgs.py's docstring) --------------------- */

enum {
    F_X = 0, F_CENTER = 3, F_VEL = 4, F_TVAR = 7, F_OPACITY = 8, F_SCALE = 9, F_ROT = 12, F_DURATION = 16,
    F_DEGREE = 17, F_DEGREE_T = 18, F_SH = 19,
    F_SH_MAX = 3 * 16 * 3, /* degree 3 with two time harmonics: 4DGS's rasterizer reads no more (forward.cu:163) */
    F_SLOTS = F_SH + F_SH_MAX
};
static const char *const fdgs_names[F_SLOTS] = {
    "x", "y", "z", "t_center", "vel_0", "vel_1", "vel_2", "t_var", "opacity", "scale_0", "scale_1", "scale_2",
    "rot_0", "rot_1", "rot_2", "rot_3", "time_duration", "sh_degree", "sh_degree_t",
    "sh4d_0", "sh4d_1", "sh4d_2", "sh4d_3", "sh4d_4", "sh4d_5", "sh4d_6", "sh4d_7", "sh4d_8", "sh4d_9", "sh4d_10",
    "sh4d_11", "sh4d_12", "sh4d_13", "sh4d_14", "sh4d_15", "sh4d_16", "sh4d_17", "sh4d_18", "sh4d_19", "sh4d_20",
    "sh4d_21", "sh4d_22", "sh4d_23", "sh4d_24", "sh4d_25", "sh4d_26", "sh4d_27", "sh4d_28", "sh4d_29", "sh4d_30",
    "sh4d_31", "sh4d_32", "sh4d_33", "sh4d_34", "sh4d_35", "sh4d_36", "sh4d_37", "sh4d_38", "sh4d_39", "sh4d_40",
    "sh4d_41", "sh4d_42", "sh4d_43", "sh4d_44", "sh4d_45", "sh4d_46", "sh4d_47", "sh4d_48", "sh4d_49", "sh4d_50",
    "sh4d_51", "sh4d_52", "sh4d_53", "sh4d_54", "sh4d_55", "sh4d_56", "sh4d_57", "sh4d_58", "sh4d_59", "sh4d_60",
    "sh4d_61", "sh4d_62", "sh4d_63", "sh4d_64", "sh4d_65", "sh4d_66", "sh4d_67", "sh4d_68", "sh4d_69", "sh4d_70",
    "sh4d_71", "sh4d_72", "sh4d_73", "sh4d_74", "sh4d_75", "sh4d_76", "sh4d_77", "sh4d_78", "sh4d_79", "sh4d_80",
    "sh4d_81", "sh4d_82", "sh4d_83", "sh4d_84", "sh4d_85", "sh4d_86", "sh4d_87", "sh4d_88", "sh4d_89", "sh4d_90",
    "sh4d_91", "sh4d_92", "sh4d_93", "sh4d_94", "sh4d_95", "sh4d_96", "sh4d_97", "sh4d_98", "sh4d_99", "sh4d_100",
    "sh4d_101", "sh4d_102", "sh4d_103", "sh4d_104", "sh4d_105", "sh4d_106", "sh4d_107", "sh4d_108", "sh4d_109",
    "sh4d_110", "sh4d_111", "sh4d_112", "sh4d_113", "sh4d_114", "sh4d_115", "sh4d_116", "sh4d_117", "sh4d_118",
    "sh4d_119", "sh4d_120", "sh4d_121", "sh4d_122", "sh4d_123", "sh4d_124", "sh4d_125", "sh4d_126", "sh4d_127",
    "sh4d_128", "sh4d_129", "sh4d_130", "sh4d_131", "sh4d_132", "sh4d_133", "sh4d_134", "sh4d_135", "sh4d_136",
    "sh4d_137", "sh4d_138", "sh4d_139", "sh4d_140", "sh4d_141", "sh4d_142", "sh4d_143"};
static const ply_schema fdgs_schema = {fdgs_names, F_SLOTS, F_SLOTS /* no integer scaling */};

static int fdgs_claims(const char *name)
{
    return !strcmp(name, "t_center") || !strcmp(name, "t_var") || !strcmp(name, "time_duration") ||
           !strcmp(name, "sh_degree") || !strcmp(name, "sh_degree_t") ||
           gaussian_ply_numbered(name, "vel_") >= 0 || gaussian_ply_numbered(name, "sh4d_") >= 0;
}

typedef struct {
    gaussian_ply_sink base; /* first: the shared callbacks take it */
    int sh_count;         /* sh4d_* declared (contiguous from sh4d_0: begin_model) */
    double duration, degree, degree_t; /* the first vertex's, which every vertex must repeat */
} fdgs_sink;

/* Properties of other layouts beside the 4DGS ones: a mixed file is no
 * model any trainer wrote, so it is refused rather than half read; and
 * sh4d_* past the 144 that degree 3 with two time harmonics has. */
static int see_property(void *user, const char *path, long line, const char *name, rr_error *err)
{
    (void)user;
    if (gaussian_dynamic_ply_refuse_other(&gaussian_fdgs_ply, path, line, name, err))
        return -1;
    if (gaussian_ply_numbered(name, "f_dc_") >= 0 || gaussian_ply_numbered(name, "f_rest_") >= 0)
        return rr_fail(err, "%s:%ld: vertex property '%s' is 3DGS's beside 4DGS ones (t_center, vel_*, sh4d_*): a "
                            "4DGS model's colour is sh4d_* alone", path, line, name);
    if (gaussian_ply_numbered(name, "sh4d_") >= F_SH_MAX)
        return rr_fail(err, "%s:%ld: vertex property '%s': 4DGS's rasterizer reads at most %d coefficients (SH "
                            "degree 3 with two time harmonics, forward.cu:73-195)", path, line, name, F_SH_MAX);
    return 0;
}

/* Every fixed property is needed, and sh4d_* from sh4d_0 without gaps:
 * a partial model is refused with the whole list of what it lacks. */
static int begin_model(void *user, const char *path, const int *present, size_t count, rr_error *err)
{
    fdgs_sink *s = user;
    char missing[600] = "";
    gaussian_ply_list_missing(missing, sizeof missing, present, fdgs_names, 0, F_SH + 1);
    if (*missing)
        return rr_fail(err, "%s: a 4DGS model lacks the vertex properties%s (scripts/convert_4dgs.py writes x y z "
                            "t_center vel_0..2 t_var opacity scale_0..2 rot_0..3 time_duration sh_degree "
                            "sh_degree_t sh4d_0..)", path, missing);
    int n = 0;
    while (n < F_SH_MAX && present[F_SH + n])
        n++;
    for (int k = n; k < F_SH_MAX; k++)
        if (present[F_SH + k])
            return rr_fail(err, "%s: property '%s' is present but '%s' is not (sh4d_* must run from sh4d_0 without "
                                "gaps)", path, fdgs_names[F_SH + k], fdgs_names[F_SH + n]);
    if (gaussian_ply_begin_3d(&s->base, path, "4DGS", count, err))
        return -1;
    s->sh_count = n;
    return 0;
}

static int store(float *dst, const double *v, int slot, char *why, size_t why_size)
{
    return gaussian_ply_store(dst, v[slot], fdgs_names[slot], why, why_size);
}

/* The degrees and T, from the first vertex: integers in range, the time
 * harmonics only at degree 3 (forward.cu:142 nests them there; the
 * converter writes 0 otherwise), and as many sh4d_* as they need. */
static int check_degrees(const fdgs_sink *s, const double *v, char *why, size_t why_size)
{
    double d = v[F_DEGREE], dt = v[F_DEGREE_T];
    if (!(v[F_DURATION] > 0))
        return gaussian_ply_bad(why, why_size, "property '%s' = %g: T of the time harmonics must be above 0",
                                fdgs_names[F_DURATION], v[F_DURATION]);
    if (d != floor(d) || d < 0 || d > GAUSSIAN_MAX_SH_DEGREE)
        return gaussian_ply_bad(why, why_size, "property '%s' = %g: expected 0, 1, 2 or 3", fdgs_names[F_DEGREE],
                                d);
    if (dt != floor(dt) || dt < 0 || dt > 2)
        return gaussian_ply_bad(why, why_size, "property '%s' = %g: expected 0, 1 or 2 (4DGS's rasterizer has two "
                                "time harmonics)", fdgs_names[F_DEGREE_T], dt);
    if (dt > 0 && d != 3)
        return snprintf(why, why_size, "sh_degree_t = %g with sh_degree = %g: 4DGS's rasterizer draws time "
                        "harmonics only at SH degree 3 (forward.cu:142)", dt, d), -1;
    int need = 3 * ((int)d + 1) * ((int)d + 1) * ((int)dt + 1);
    if (s->sh_count != need)
        return snprintf(why, why_size, "sh_degree %g and sh_degree_t %g need %d sh4d_* properties "
                        "(3 (sh_degree + 1)^2 (sh_degree_t + 1)), the header declares %d", d, dt, need,
                        s->sh_count), -1;
    return 0;
}

/* The first vertex sets the degrees and allocates; every later one must
 * repeat them (they are one model's, written in every vertex). */
static int model_constants(fdgs_sink *s, const double *v, char *why, size_t why_size)
{
    gaussian_model *m = s->base.m;
    if (m->mean) {
        const double first[3] = {s->duration, s->degree, s->degree_t};
        for (int k = 0; k < 3; k++)
            if (v[F_DURATION + k] != first[k])
                return snprintf(why, why_size, "property '%s' = %g differs from the first vertex's %g (one "
                                "value for the whole model)", fdgs_names[F_DURATION + k], v[F_DURATION + k],
                                first[k]), -1;
        return 0;
    }
    if (check_degrees(s, v, why, why_size))
        return -1;
    s->duration = v[F_DURATION], s->degree = v[F_DEGREE], s->degree_t = v[F_DEGREE_T];
    int d = (int)s->degree, dt = (int)s->degree_t;
    m->sh_degree = d, m->sh_coeffs = (d + 1) * (d + 1) * (dt + 1);
    if (gaussian_ply_allocate(m, s->base.declared, gaussian_fdgs_alloc, why, why_size))
        return -1;
    gaussian_fdgs_of(m)->time_duration = s->duration, gaussian_fdgs_of(m)->sh_degree_t = dt;
    return 0;
}

/* The static arrays (gaussian_fdgs.h): the canonical mean within
 * RR_MAX_REACH, exp(scale) within RR_MAX_REACH, the unit
 * quaternion of rot_0..3 (the converter's is unit up to float rounding;
 * only zero is refused), sigmoid of the opacity, sh4d as it runs
 * (coefficient S k + j of channel c is sh4d_<3 (S k + j) + c>, the model's
 * own order). */
static int store_static(gaussian_model *m, size_t i, const double *v, int sh_count, char *why, size_t why_size)
{
    if (gaussian_ply_store_mean_scale(m, i, v, fdgs_names, F_X, F_SCALE, 3, why, why_size))
        return -1;
    for (int k = 0; k < sh_count; k++)
        if (store(&m->sh[(size_t)sh_count * i + (size_t)k], v, F_SH + k, why, why_size))
            return -1;
    m->opacity[i] = (float)(1.0 / (1.0 + exp(-v[F_OPACITY])));
    return gaussian_ply_unit_quaternion(&v[F_ROT], &m->rotation[4 * i], why, why_size);
}

/* The motion as stored; t_var, a variance divided by, must be above 0 as
 * the float held. */
static int store_motion(gaussian_fdgs *d, size_t i, const double *v, char *why, size_t why_size)
{
    if (store(&d->t_center[i], v, F_CENTER, why, why_size) || store(&d->t_var[i], v, F_TVAR, why, why_size))
        return -1;
    if (!(d->t_var[i] > 0))
        return gaussian_ply_bad(why, why_size, "property '%s' = %g: the temporal marginal's variance must be "
                                "above 0", fdgs_names[F_TVAR], v[F_TVAR]);
    for (int k = 0; k < 3; k++)
        if (store(&d->velocity[3 * i + k], v, F_VEL + k, why, why_size))
            return -1;
    return 0;
}

static int add_gaussian(void *user, const double *v, const int *present, char *why, size_t why_size)
{
    fdgs_sink *s = user;
    gaussian_model *m = s->base.m;
    if (gaussian_ply_check_finite(v, present, fdgs_names, F_SLOTS, why, why_size) ||
        model_constants(s, v, why, why_size))
        return -1;
    size_t i = s->base.next;
    if (store_motion(gaussian_fdgs_of(m), i, v, why, why_size) || store_static(m, i, v, s->sh_count, why, why_size))
        return -1;
    m->count = ++s->base.next;
    return 0;
}

static int fdgs_load(const char *name, const char *data, size_t len, input_file *src, gaussian_kind kind,
                     gaussian_model *m, rr_error *err)
{
    fdgs_sink sink = {{m, kind, 0, 0}, 0, 0, 0, 0};
    ply_visitor v = {begin_model, add_gaussian, &sink, see_property};
    return gaussian_ply_load_layout(name, data, len, src, &fdgs_schema, &v, m, err);
}

const gaussian_dynamic_ply_reader gaussian_fdgs_ply = {"4DGS", "4DGS's", "t_center, vel_*, sh4d_*", fdgs_claims,
                                                       fdgs_load};
