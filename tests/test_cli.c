/* cli.c: option parsing bounds, frame-name patterns, same-file checks. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd/cli.h"
#include "harness.h"

TEST(cli_numbers_are_checked_whole_and_in_range)
{
    int v;
    rr_error e;
    CHECK(cli_int("--n", "12", 1, 100, &v, &e) == 0 && v == 12);
    CHECK(cli_int("--n", "12x", 1, 100, &v, &e) != 0 && strstr(e.msg, "--n") && strstr(e.msg, "12x"));
    CHECK(cli_int("--n", "101", 1, 100, &v, &e) != 0);
    CHECK(cli_int("--n", "99999999999999999999", 1, 100, &v, &e) != 0);
    double d;
    CHECK(cli_double("--x", "nan", 0, &d, &e) != 0);
    CHECK(cli_double("--x", "-1", 0, &d, &e) != 0);
    int w, h;
    CHECK(cli_resolution("--res", "640x480", &w, &h, &e) == 0 && w == 640 && h == 480);
    CHECK(cli_resolution("--res", "640x0", &w, &h, &e) != 0);
}

TEST(cli_frame_patterns)
{
    char out[64];
    CHECK(cli_frame_pattern_ok("a.%04d.exr") && cli_frame_pattern_ok("a%d.exr") && cli_frame_pattern_ok("a%4d"));
    CHECK(!cli_frame_pattern_ok("render_50%.exr") && !cli_frame_pattern_ok("a%d%d") && !cli_frame_pattern_ok("a%s"));
    cli_frame_path("a.%04d.exr", 7, out, sizeof out);
    CHECK(!strcmp(out, "a.0007.exr"));
    cli_frame_path("a%4d", -3, out, sizeof out);
    CHECK(!strcmp(out, "a  -3"));
    cli_frame_path("render_50%.exr", 7, out, sizeof out); /* no field: the name as given */
    CHECK(!strcmp(out, "render_50%.exr"));
}

TEST(cli_same_file_sees_through_spellings_and_links)
{
    char dir[] = "/tmp/refrender-cli-XXXXXX", a[128], b[128], hard[128], other[128];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(a, sizeof a, "%s/a.exr", dir);
    snprintf(b, sizeof b, "%s/../%s/./a.exr", dir, strrchr(dir, '/') + 1);
    snprintf(hard, sizeof hard, "%s/hard.exr", dir);
    snprintf(other, sizeof other, "%s/b.exr", dir);
    CHECK(cli_same_file(a, b)); /* neither exists yet */
    FILE *f = fopen(a, "w");
    fclose(f);
    CHECK(link(a, hard) == 0);
    CHECK(cli_same_file(a, b) && cli_same_file(a, hard) && !cli_same_file(a, other));
    unlink(a), unlink(hard), rmdir(dir);
}
