/* EXR writing and reading through the OpenEXR C API. */
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "exr.h"
#include "harness.h"

TEST(exr_round_trip_is_exact_and_keeps_metadata)
{
    int w = 37, h = 21; /* odd sizes cross ZIP's 16-line chunks */
    float *px = malloc((size_t)w * h * 4 * sizeof *px);
    for (int i = 0; i < w * h * 4; i++)
        px[i] = (float)(i % 7) * 0.25f - 0.3f + (float)i * 1e-3f; /* distinct per channel */
    char path[128];
    snprintf(path, sizeof path, "/tmp/refrender-test-%d.exr", (int)getpid());
    exr_string_attr attrs[1] = {{"refrender:seed", "42"}};
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
