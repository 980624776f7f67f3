/* Render states (output.c): exact round trips, and every field of a state
 * read from a file checked before it is used (a damaged state is refused,
 * never merged or resumed from). */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "formats/exr.h"
#include "harness.h"
#include "io/output.h"
#include "render/integrator.h"

static const char *state_path(const char *name)
{
    static char buf[256];
    snprintf(buf, sizeof buf, "/tmp/refrender-test-%d-%s", (int)getpid(), name);
    return buf;
}

/* The identity attributes a state must carry, for a w x h render. */
static void identity(attr_list *a, int w, int h)
{
    static const char *const keys[] = {"refrender:build", "refrender:sceneHash", "refrender:inputsHash", "refrender:sampler",
                                       "refrender:spp", "refrender:tspp", "refrender:seed", "refrender:epsilon",
                                       "refrender:kernelSigma", "refrender:shutter", "refrender:weightFunction",
                                       "refrender:timeFactor", "refrender:batches", "refrender:timeIntegration",
                                       "refrender:parameters", "refrender:parametersHash", "refrender:weightHash",
                                       "refrender:pixelFilter", "refrender:blurSpace", "refrender:gaussians", "refrender:gaussiansHash",
                                       "refrender:rollingShutter", NULL};
    a->n = 0;
    for (const char *const *k = keys; *k; k++)
        attrs_set(a, *k, "1");
    attrs_set(a, "refrender:resolution", "%dx%d", w, h);
}

/* A w x h image whose pixels hold `batches` batch estimates each, spread
 * over negative, fractional and clamped values. */
static void fill(image *img, int w, int h, int batches)
{
    image_alloc(img, w, h);
    for (int i = 0; i < w * h; i++)
        for (int b = 0; b < batches; b++) {
            double est[4] = {0.1 * i - 1.3 * b, 1.0 / (1 + i + b), -3e6 * (i == 1), 0.5};
            film_add_batch(&img->px[i], est);
        }
}

static const char *read_error(const char *path)
{
    static rr_error e;
    image img;
    attr_list a;
    uint32_t begin, end;
    e.msg[0] = 0;
    if (output_read_state(path, &img, &a, &begin, &end, &e) == 0) {
        image_free(&img);
        e.msg[0] = 0;
    }
    return e.msg;
}

TEST(state_round_trip_is_exact)
{
    image img, back;
    static attr_list a, b;
    fill(&img, 5, 3, 3);
    identity(&a, 5, 3);
    rr_error e;
    const char *p = state_path("s.exr");
    CHECK(output_write_state(p, &img, 2, 5, &a, &e) == 0);
    uint32_t begin, end;
    CHECK(output_read_state(p, &back, &b, &begin, &end, &e) == 0);
    CHECK(begin == 2 && end == 5 && back.width == 5 && back.height == 3);
    CHECK(!memcmp(img.px, back.px, 15 * sizeof *img.px));
    CHECK(!strcmp(attrs_get(&b, "refrender:resolution"), "5x3"));
    image_free(&img), image_free(&back);
    unlink(p);
}

TEST(state_window_must_match_its_resolution)
{
    image img;
    static attr_list a;
    fill(&img, 8, 3, 1);
    identity(&a, 4, 3); /* the 4x3 label on an 8x3 window overflowed merge */
    rr_error e;
    const char *p = state_path("w.exr");
    CHECK(output_write_state(p, &img, 0, 1, &a, &e) == 0);
    CHECK(strstr(read_error(p), "data window 8x3 differs from refrender:resolution '4x3'") != NULL);
    image_free(&img);
    unlink(p);
}

TEST(state_channels_must_have_their_types)
{
    uint32_t words[4] = {1, 1, 1, 1};
    static attr_list a;
    identity(&a, 2, 2);
    attrs_set(&a, "refrender:state", "batches 0-1");
    exr_string_attr sa[ATTR_MAX];
    for (int i = 0; i < a.n; i++)
        sa[i] = (exr_string_attr){a.key[i], a.value[i], RR_ATTR_TEXT};
    exr_channel chs[1] = {{"state.batches", EXR_CHANNEL_FLOAT, words, 4}};
    rr_error e;
    const char *p = state_path("t.exr");
    CHECK(exr_write(p, 2, 2, chs, 1, sa, a.n, &e) == 0);
    CHECK(strstr(read_error(p), "channel state.batches is float, expected uint") != NULL);
    unlink(p);
}

TEST(state_sums_no_render_can_make_are_refused)
{
    image img;
    static attr_list a;
    fill(&img, 2, 2, 2);
    identity(&a, 2, 2);
    rr_error e;
    const char *p = state_path("x.exr");
    const char *why = "sums that no render can produce";
    img.px[3].sum[0] = INT64_MAX; /* would overflow film_merge (UBSan) */
    CHECK(output_write_state(p, &img, 0, 2, &a, &e) == 0 && strstr(read_error(p), why));
    img.px[3].sum[0] = 0, img.px[3].sumsq[1] = -1; /* negative sum of squares */
    CHECK(output_write_state(p, &img, 0, 2, &a, &e) == 0 && strstr(read_error(p), why));
    img.px[3].sumsq[1] = 0, img.px[3].sum[1] = 5; /* sum^2 > B * sum of squares */
    CHECK(output_write_state(p, &img, 0, 2, &a, &e) == 0 && strstr(read_error(p), why));
    img.px[3].sum[1] = 0, img.px[3].batches = FILM_MAX_BATCHES + 1;
    CHECK(output_write_state(p, &img, 0, 2, &a, &e) == 0 && strstr(read_error(p), why));
    image_free(&img);
    unlink(p);
}

TEST(film_check_accepts_every_state_a_render_makes)
{
    pixel_state p = {0};
    double extreme[4] = {FILM_LIMIT, -FILM_LIMIT, 1e300, 0};
    for (int b = 0; b < 1000; b++)
        film_add_batch(&p, extreme);
    CHECK(film_check(&p) == 0);
    pixel_state q = {0};
    CHECK(film_check(&q) == 0);
}

/* Overwrites the box2i attribute `name` of an EXR header in place. */
static int patch_box(const char *path, const char *name, const int32_t box[4])
{
    FILE *f = fopen(path, "r+b");
    char buf[4096];
    size_t n = fread(buf, 1, sizeof buf, f);
    char key[64];
    size_t klen = (size_t)snprintf(key, sizeof key, "%s%cbox2i", name, 0) + 1;
    char *at = memmem(buf, n, key, klen);
    if (at) {
        memcpy(at + klen + 4, box, 4 * sizeof *box); /* after the 4-byte size */
        fseek(f, 0, SEEK_SET);
        fwrite(buf, 1, n, f);
    }
    fclose(f);
    return at != NULL;
}

TEST(huge_data_windows_are_refused_before_allocating)
{
    /* a 1 x 1 image whose header then claims 20000 x 20000 pixels (2.5 KB
     * headers like it made the reader allocate gigabytes) is refused by its
     * size before anything is allocated for it */
    float px[4] = {0};
    rr_error e;
    const char *p = state_path("big.exr");
    CHECK(exr_write_rgba(p, 1, 1, px, NULL, 0, &e) == 0);
    const int32_t box[4] = {0, 0, 19999, 19999};
    CHECK(patch_box(p, "dataWindow", box) && patch_box(p, "displayWindow", box));
    int w, h;
    CHECK(exr_read_size(p, &w, &h, &e) != 0 && strstr(e.msg, "data window 20000x20000 is empty or larger than"));
    unlink(p);
}

/* Every counter of a built-in integrator row (exact time's unresolved
 * share; render/counters.h) is a share per traced ray, and merges to the
 * ray-weighted mean: states of 100 and 300 rays with shares 0.1 and 0.4
 * hold 10 + 120 = 130 share-rays of 400 rays, 0.325 (unequal rays, so a
 * plain mean, 0.25, or either state's own share fails; so does a counter
 * whose attribute is no ROLE_PER_RAY row of output.c's table, which merge
 * and resume would not read). A state without the counter cannot join one
 * with it. */
static void check_counter_merges(const char *key)
{
    static attr_list merged, b; /* (330 KB each) */
    rr_error e;
    merged.n = b.n = 0;
    attrs_set(&merged, ATTR_RAYS, "100"), attrs_set(&merged, key, "0.1");
    attrs_set(&b, ATTR_RAYS, "300"), attrs_set(&b, key, "0.4");
    CHECK(attrs_combine(&merged, "a.exr", &b, "b.exr", &e) == 0);
    printf("    %s: merged %s of %s rays\n", key, attrs_get(&merged, key), attrs_get(&merged, ATTR_RAYS));
    CHECK(!strcmp(attrs_get(&merged, key), "0.325"));
    CHECK(!strcmp(attrs_get(&merged, ATTR_RAYS), "400"));
    b.n = 0;
    attrs_set(&b, ATTR_RAYS, "300");
    CHECK(attrs_combine(&merged, "a.exr", &b, "b.exr", &e) == -1);
    CHECK(strstr(e.msg, "but b.exr lacks it") && strstr(e.msg, key));
}

TEST(every_built_in_counter_merges_to_the_ray_weighted_mean)
{
    static const char *const ids[] = {"surfels", "gaussians", "exact"};
    int counters = 0;
    for (int k = 0; k < 3; k++) {
        const integrator_ops *row = integrator_named(ids[k]);
        CHECK(row != NULL);
        for (int i = 0; row && i < row->ncounters; i++, counters++) {
            CHECK(row->counters[i].scale == COUNTER_SHARE_PER_RAY);
            check_counter_merges(row->counters[i].attribute);
        }
    }
    CHECK(counters >= 1); /* exact time's, at least */
}
