/* film.c: exact fixed-point sums (order-independent, mergeable), the
 * variance of the mean, clamping, and the image's resolved values. */
#include <stdlib.h>
#include <string.h>

#include "render/film.h"
#include "harness.h"

static void add_all(pixel_state *p, const double (*est)[4], const int *order, int n)
{
    memset(p, 0, sizeof *p);
    for (int i = 0; i < n; i++)
        film_add_batch(p, est[order[i]]);
}

TEST(film_sums_do_not_depend_on_order_or_split)
{
    double est[6][4] = {{0.1, -2.5, 1e-7, 1}, {3.3, 0.2, 7, 0}, {-1e5, 0.3, 0.7, 1},
                        {1.0 / 3, 2.0 / 3, 1.0 / 7, 0}, {5, 5, 5, 1}, {0.123456789, 9.87654321, -3, 1}};
    int forward[6] = {0, 1, 2, 3, 4, 5}, backward[6] = {5, 4, 3, 2, 1, 0}, shuffled[6] = {3, 0, 5, 1, 4, 2};
    pixel_state a, b, c, first, second;
    add_all(&a, est, forward, 6);
    add_all(&b, est, backward, 6);
    add_all(&c, est, shuffled, 6);
    CHECK(!memcmp(&a, &b, sizeof a) && !memcmp(&a, &c, sizeof a));
    add_all(&first, est, forward, 2); /* passes: batches 0-1 and 2-5 */
    add_all(&second, est, forward + 2, 4);
    film_merge(&first, &second);
    CHECK(!memcmp(&a, &first, sizeof a));
    CHECK(film_check(&a) == 0);
}

TEST(film_variance_is_that_of_the_batch_mean)
{
    /* estimates 1, 2, 3, 4 (exact in 2^-24 steps): mean 2.5, sample variance
     * s^2 = 5/3, variance of the mean s^2 / 4 = 5/12 */
    pixel_state p = {0};
    for (int b = 1; b <= 4; b++) {
        double e[4] = {b, 2 * b, 7, -b};
        film_add_batch(&p, e);
    }
    double mean[4], var[4];
    film_resolve(&p, mean, var);
    CHECK_NEAR(mean[0], 2.5, 0);
    CHECK_NEAR(var[0], 5.0 / 12, 1e-15);
    CHECK_NEAR(var[1], 4 * 5.0 / 12, 1e-15); /* scaling by 2 scales the variance by 4 */
    CHECK_NEAR(var[2], 0, 0);                /* constant: exactly zero, no cancellation */
    CHECK_NEAR(var[3], 5.0 / 12, 1e-15);
    CHECK_NEAR(film_max_stderr(&p), sqrt(4 * 5.0 / 12), 1e-15);
    pixel_state one = {0};
    film_add_batch(&one, (double[4]){1, 1, 1, 1});
    film_resolve(&one, mean, var);
    CHECK(isnan(var[0]) && isinf(film_max_stderr(&one))); /* one batch: no estimate */
}

TEST(film_clamps_and_counts_values_it_cannot_sum_exactly)
{
    pixel_state p = {0};
    CHECK(film_add_batch(&p, (double[4]){2 * FILM_LIMIT, -2 * FILM_LIMIT, NAN, 0.5}) == 1);
    CHECK(film_add_batch(&p, (double[4]){1, 1, 1, 1}) == 0);
    double mean[4], var[4];
    film_resolve(&p, mean, var);
    CHECK_NEAR(mean[0], (FILM_LIMIT + 1) / 2, 0);
    CHECK_NEAR(mean[1], (-FILM_LIMIT + 1) / 2, 0);
    CHECK_NEAR(mean[2], 0.5, 0); /* NaN counted as 0 */
    CHECK(film_check(&p) == 0);
}

TEST(image_resolve_reports_means_errors_and_samples)
{
    image img;
    CHECK(image_alloc(&img, 2, 1) == 0);
    for (int b = 0; b < 3; b++)
        film_add_batch(&img.px[0], (double[4]){b, 0, 0, 1});
    float rgba[8], var[8], se[8], samples[2];
    image_resolve(&img, 10, rgba, var, se, samples);
    CHECK_NEAR(rgba[0], 1, 0);
    CHECK_NEAR(var[0], 1.0 / 3, 1e-7); /* s^2 = 1, over 3 batches */
    CHECK_NEAR(se[0], sqrt(1.0 / 3), 1e-7);
    CHECK_NEAR(samples[0], 30, 0);
    CHECK_NEAR(samples[1], 0, 0);
    CHECK(rgba[4] == 0 && isnan(var[4])); /* no batches */
    image_free(&img);
}
