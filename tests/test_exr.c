/* EXR writing and reading through the OpenEXR C API. */
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "formats/exr.h"
#include "harness.h"

TEST(exr_round_trip_is_exact_and_keeps_metadata)
{
    int w = 37, h = 21; /* odd sizes cross ZIP's 16-line chunks */
    float *px = malloc((size_t)w * h * 4 * sizeof *px);
    for (int i = 0; i < w * h * 4; i++)
        px[i] = (float)(i % 7) * 0.25f - 0.3f + (float)i * 1e-3f; /* distinct per channel */
    char path[128];
    snprintf(path, sizeof path, "/tmp/refrender-test-%d.exr", (int)getpid());
    exr_string_attr attrs[1] = {{"refrender:seed", "42", RR_ATTR_TEXT}};
    rr_error e;
    CHECK(exr_write_rgba(path, w, h, px, attrs, 1, &e) == 0);
    int rw, rh;
    float *back = NULL;
    CHECK(exr_read_rgba(path, &rw, &rh, &back, &e) == 0);
    CHECK(rw == w && rh == h);
    CHECK(back && memcmp(back, px, (size_t)w * h * 4 * sizeof *px) == 0);
    char val[64];
    CHECK(exr_read_string_attr(path, "refrender:seed", val, sizeof val, &e) == 0 && !strcmp(val, "42"));
    CHECK(exr_read_string_attr(path, "nope", val, sizeof val, &e) != 0);
    unlink(path);
    free(back);
    free(px);
}

TEST(exr_write_failure_leaves_no_file)
{
    float px[4] = {0};
    rr_error e;
    CHECK(exr_write_rgba("/nonexistent-dir/x.exr", 1, 1, px, NULL, 0, &e) != 0);
    CHECK(strstr(e.msg, "/nonexistent-dir/x.exr") != NULL);
    struct stat st;
    CHECK(stat("/nonexistent-dir/x.exr", &st) != 0);
}

TEST(exr_read_rejects_non_exr)
{
    char path[128];
    snprintf(path, sizeof path, "/tmp/refrender-test-%d.txt", (int)getpid());
    FILE *f = fopen(path, "w");
    fputs("not an image", f);
    fclose(f);
    int w, h;
    float *px;
    rr_error e;
    CHECK(exr_read_rgba(path, &w, &h, &px, &e) != 0);
    unlink(path);
}

/* ---- ZIP round trip over chunk contents (OpenEXR's ZIP bug #2306: exr.c) ---- */

static uint32_t xorshift32(uint32_t *s)
{
    *s ^= *s << 13, *s ^= *s >> 17, *s ^= *s << 5;
    return *s;
}

/* Writes nch planar 32-bit channels (the first nfloat float, the rest uint)
 * of w x h values from `data` and reads each back; 1 if all bytes survive. */
static int round_trips(const char *path, int w, int h, int nch, int nfloat, uint32_t *data)
{
    size_t n = (size_t)w * h;
    char names[32][16];
    exr_channel chs[32] = {{0}};
    for (int c = 0; c < nch; c++) {
        snprintf(names[c], sizeof names[c], "c%02d", c);
        chs[c] = (exr_channel){names[c], c < nfloat ? EXR_CHANNEL_FLOAT : EXR_CHANNEL_UINT, data + c * n, 4};
    }
    rr_error e;
    if (exr_write(path, w, h, chs, nch, NULL, 0, &e))
        return 0;
    uint32_t *back = malloc(n * sizeof *back);
    int ok = 1;
    for (int c = 0; c < nch && ok; c++) {
        exr_channel ch = chs[c];
        ch.base = back;
        ok = !exr_read_channel(path, &ch, 0, NULL, &e) && !memcmp(back, data + c * n, n * sizeof *back);
    }
    free(back);
    return ok;
}

/* Fills the channels with values drawn from a palette of `colors` random
 * 32-bit words: few colors compress well, many do not, and in between zlib's
 * output is sometimes exactly as long as the packed chunk. Floats stay
 * finite (a NaN's payload may legally change on conversion). */
static void fill_palette(uint32_t *data, size_t count, int colors, uint32_t *rng)
{
    uint32_t palette[256];
    for (int i = 0; i < colors; i++)
        palette[i] = xorshift32(rng) & 0xbfffffffu;
    for (size_t i = 0; i < count; i++)
        data[i] = palette[xorshift32(rng) % (uint32_t)colors];
}

TEST(exr_zip_round_trip_is_exact_for_any_chunk_content)
{
    /* The channel sets refrender writes: final image without and with error
     * channels (4 + 1, 12 + 1 floats) and a render state (4 float + 25 uint). */
    static const int sets[3][2] = {{5, 5}, {13, 13}, {29, 4}};
    /* in a directory of its own: each write lists its directory (atomicfile.c's
     * stale temporaries), and a shared /tmp may hold hundreds of entries */
    char dir[] = "/tmp/refrender-test-zip-XXXXXX", path[128];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, sizeof path, "%s/zip.exr", dir);
    uint32_t rng = 2463534242u;
    int failures = 0, cases = 0;
    uint32_t *data = malloc((size_t)64 * 17 * 29 * sizeof *data);
    for (int w = 1; w <= 64; w += 1 + (w > 8) * 6)
        for (int h = 1; h <= 17; h += 1 + (h > 2) * 3)
            for (int s = 0; s < 3; s++)
                for (int colors = 1; colors <= 256; colors *= 2, cases++) {
                    size_t count = (size_t)w * h * sets[s][0];
                    fill_palette(data, count, colors, &rng);
                    failures += !round_trips(path, w, h, sets[s][0], sets[s][1], data);
                }
    unlink(path);
    rmdir(dir);
    free(data);
    if (failures)
        printf("  %d of %d images did not survive the round trip\n", failures, cases);
    CHECK(failures == 0);
}

/* The reproducer: a 1x1 final image R=G=B=A=0.32, samples=100 (20
 * bytes) that zlib compresses to exactly 20 bytes. */
TEST(exr_zip_equal_size_chunk_reads_back)
{
    float px[5] = {0.32f, 0.32f, 0.32f, 0.32f, 100.0f};
    char path[128];
    snprintf(path, sizeof path, "/tmp/refrender-test-zip1-%d.exr", (int)getpid());
    CHECK(round_trips(path, 1, 1, 5, 5, (uint32_t *)px));
    unlink(path);
}
