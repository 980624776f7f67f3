/* render/noise.c: the noise a final image reached (each pixel's largest RGB
 * standard error over the image, its batch range), and render.c's plan of
 * the pixel batches a render will take, which the progress line measures
 * against. Expectations from the definitions: two or four batch estimates
 * +-e give a standard error of e / sqrt(B - 1) (s^2 / B with s^2 = B e^2 /
 * (B - 1)); a standard error falls as 1 / sqrt(batches). */
#include <math.h>
#include <string.h>

#include "render/noise.h"
#include "render/render.h"
#include "harness.h"

/* B batch estimates alternating +-e in R, G and B (B even): standard error
 * e / sqrt(B - 1) in each; green's is scaled by `green` (the largest). */
static void pixel_with_stderr(pixel_state *p, uint32_t batches, double se, double green)
{
    memset(p, 0, sizeof *p);
    double e = se * sqrt((double)batches - 1.0);
    for (uint32_t b = 0; b < batches; b++) {
        double sign = b % 2 ? -1.0 : 1.0;
        film_add_batch(p, (double[4]){0.5 + sign * e / green, 0.5 + sign * e, 0.5, 1.0});
    }
}

TEST(noise_stats_are_the_mean_nearest_rank_99th_percentile_and_max_of_each_pixels_largest_stderr)
{
    image img;
    CHECK(image_alloc(&img, 101, 1) == 0);
    for (int i = 0; i < 100; i++) /* standard errors 0.01 .. 1.00 in green, smaller in red */
        pixel_with_stderr(&img.px[i], i == 7 ? 6 : 2, (i + 1) / 100.0, 2.0);
    /* pixel 100 holds no batch: outside a crop window, not counted */
    noise_stats n;
    CHECK(noise_stats_of(&img, &n) == 0 && noise_has_stderr(&n));
    CHECK(n.pixels == 100 && n.batches_min == 2 && n.batches_max == 6);
    CHECK_NEAR(n.mean, 0.505, 1e-6);
    CHECK_NEAR(n.p99, 0.99, 1e-6); /* rank ceil(0.99 * 100) = 99 of the sorted 100 */
    CHECK_NEAR(n.max, 1.0, 1e-6);
    char text[160];
    noise_text(&n, text, sizeof text);
    CHECK(strstr(text, "mean 129, 99th percentile 252, max 255 8-bit levels (0.505, 0.99, 1)") != NULL);
    image_free(&img);
}

TEST(noise_stats_of_one_batch_images_have_no_figures)
{
    image img;
    CHECK(image_alloc(&img, 3, 1) == 0);
    for (int i = 0; i < 3; i++)
        film_add_batch(&img.px[i], (double[4]){0.25, 0.5, 0.75, 1});
    noise_stats n;
    CHECK(noise_stats_of(&img, &n) == 0 && !noise_has_stderr(&n));
    CHECK(n.pixels == 3 && n.batches_min == 1 && n.batches_max == 1 && isnan(n.mean));
    image_free(&img);
}

TEST(render_plans_the_batches_each_pixels_stderr_says_it_needs)
{
    render_settings rs = render_settings_default();
    rs.batches = 4, rs.max_batches = 32, rs.target_error = 0.01;
    image img;
    CHECK(image_alloc(&img, 6, 1) == 0);
    pixel_with_stderr(&img.px[0], 4, 0.02, 1.0);   /* twice the target: 4 (2)^2 = 16 batches */
    pixel_with_stderr(&img.px[1], 4, 0.005, 1.0);  /* below it: stays at 4 */
    pixel_with_stderr(&img.px[2], 4, 1.0, 1.0);    /* 40000 wanted: the cap, 32 */
    pixel_with_stderr(&img.px[3], 4, 0.0101, 1.0); /* 4.08 wanted: at least one more, 5 */
    pixel_with_stderr(&img.px[4], 2, 0.02, 1.0);   /* 2 (2)^2 = 8 */
    /* pixel 5 holds nothing yet: the first 4 */
    CHECK(render_planned_pixel_batches(&rs, &img) == 16 + 4 + 32 + 5 + 8 + 4);
    rs.target_error = 0; /* without a target every pixel takes B */
    CHECK(render_planned_pixel_batches(&rs, &img) == 6 * 4);
    rs.crop_x0 = 1, rs.crop_x1 = 3, rs.crop_y0 = 0, rs.crop_y1 = 1; /* a crop window's pixels only */
    CHECK(render_planned_pixel_batches(&rs, &img) == 2 * 4);
    image_free(&img);
}
