/* The render loop: batches, target error and resumes (render.c). */
#include <stdlib.h>
#include <string.h>

#include <unistd.h>

#include "harness.h"
#include "render/render.h"
#include "formats/gaussian_ply.h"
#include "scenexml/scene_xml.h"

/* A disk moving across a 32x16 image: two 16x16 tiles, and pixels whose
 * noise differs (edges, interior, background), so a target error stops them
 * after different numbers of batches. */
static const char *const MOVING_DISK =
    "<scene><camera position='0 0 0' lookat='0 0 -1' up='0 1 0' fov='20' width='32' height='16'/>"
    "<object><pointModel><splat center='-1 0 -10' normal='0 0 1' radius='1.1' color='1 0.5 0.25'/>"
    "</pointModel><material shading='unlit'/><animation><linear velocity='2.5 0 0'/></animation></object>"
    "</scene>";

static render_settings target_settings(uint32_t max_batches)
{
    render_settings rs = render_settings_default();
    rs.smp.seed = 7, rs.smp.tspp = 4, rs.smp.time_factor = 4;
    rs.threads = 2;
    rs.batches = 2, rs.max_batches = max_batches, rs.target_error = 0.03;
    return rs;
}

static int render_into(const accel *a, uint32_t max_batches, image *img)
{
    volatile sig_atomic_t cancel = 0;
    render_settings rs = target_settings(max_batches);
    rr_error e;
    return render_image(a, &rs, img, NULL, &cancel, &e);
}

static int same_pixels(const image *a, const image *b)
{
    return !memcmp(a->px, b->px, (size_t)a->width * a->height * sizeof *a->px);
}

/* A checkpoint is written between tiles, so it can hold round r for the
 * first tile and round r - 1 for the second. Such a state is built here
 * from two renders capped at r and r + 1 batches (each pixel's batches
 * depend on that pixel only), resumed, and must give the uninterrupted
 * image for every r (a regression: the loop used to stop when no pixel of the
 * current round wanted a batch, although pixels a round ahead still did). */
TEST(render_resumed_mid_round_equals_uninterrupted)
{
    enum { BATCHES = 2, MAX = 14 };
    scene s;
    accel *a;
    rr_error e;
    CHECK(scene_load_memory(MOVING_DISK, strlen(MOVING_DISK), "mem.xml", ".", &s, &e) == 0);
    accel_settings set = {s.epsilon, s.kernel_sigma, 1};
    CHECK(accel_build(&s, &set, &a, &e) == 0);
    image full, before, after;
    CHECK(image_alloc(&full, 32, 16) == 0 && render_into(a, MAX, &full) == 0);
    int mismatches = 0, rounds_tried = 0;
    for (uint32_t r = BATCHES; r < MAX; r++) {
        CHECK(image_alloc(&before, 32, 16) == 0 && render_into(a, r, &before) == 0);
        CHECK(image_alloc(&after, 32, 16) == 0 && render_into(a, r + 1, &after) == 0);
        for (int y = 0; y < 16; y++) /* the first tile has finished round r */
            memcpy(&before.px[y * 32], &after.px[y * 32], 16 * sizeof *before.px);
        CHECK(render_into(a, MAX, &before) == 0);
        mismatches += !same_pixels(&before, &full);
        rounds_tried++;
        image_free(&before);
        image_free(&after);
    }
    if (mismatches)
        printf("    %d of %d mid-round resumes differ from the uninterrupted render\n", mismatches, rounds_tried);
    CHECK(mismatches == 0);
    /* the target error spread the pixels over several batch counts */
    uint32_t least = MAX, most = 0;
    for (int i = 0; i < 32 * 16; i++) {
        least = full.px[i].batches < least ? full.px[i].batches : least;
        most = full.px[i].batches > most ? full.px[i].batches : most;
    }
    CHECK(least == BATCHES && most > least + 2);
    image_free(&full);
    accel_free(a);
    scene_free(&s);
}

/* A sphere (unlit, colour c) crossing the view of a one-pixel camera
 * looking down -z: its centre at x = -15 + 10 t on the plane z = -10,
 * radius 2.5, so the pixel's ray (the z axis) meets it while |x| < 2.5,
 * for t in (1.25, 1.75). With <frames rate='1'> and the shutter [0, 1],
 * frame 0 ([0, 1]) never sees it and frame 1 ([1, 2]) sees it for exactly
 * half its box shutter: coverage 1/2 and colour c/2 on a black
 * background. The thesis sampler with one spatial sample, 4 times and
 * time factor 1 puts one time in each quarter of the shutter
 * (src/SAMPLING.md), and (1.25, 1.75) is two whole quarters: the
 * estimate is exact, whatever the jitter. */
static const char *const CROSSING_SPHERE =
    "<scene><camera position='0 0 0' lookat='0 0 -1' up='0 1 0' fov='20' width='1' height='1'/>"
    "<shutter open='0' close='1' weight='box'/><frames rate='1'/>"
    "<object><sphere center='-15 0 -10' radius='2.5' color='1 0.5 0.25'/><material shading='unlit'/>"
    "<animation><linear velocity='10 0 0'/></animation></object></scene>";

/* The one pixel of a render through accel (of the scene it was built or
 * retimed for: render_image takes no other) into rgba. */
static int render_pixel(const accel *a, float rgba[4])
{
    render_settings rs = render_settings_default();
    rs.smp.kind = SAMPLER_THESIS, rs.smp.grid = 1, rs.smp.tspp = 4, rs.smp.time_factor = 1;
    rs.filter = PIXEL_FILTER_POINT;
    volatile sig_atomic_t cancel = 0;
    image img;
    rr_error e;
    float var[4], se[4], n[1];
    if (image_alloc(&img, 1, 1))
        return -1;
    int rc = render_image(a, &rs, &img, NULL, &cancel, &e);
    if (rc)
        printf("    %s\n", e.msg);
    else
        image_resolve(&img, 1, rgba, var, se, n);
    image_free(&img);
    return rc;
}

/* The shutter's one owner is the scene rendered: a frame's scene
 * (scene_for_shutter) holds the frame's shutter, accel_build and
 * accel_retime take their swept interval from it, and render_image reaches
 * the scene only through the accel, so a frame is rendered over its own
 * shutter with bounds built for it (CROSSING_SPHERE's analytic values).
 * Planted: accel_retime keeping the interval of the frame before (frame
 * 0's bounds miss the sphere in frame 1) fails it. */
TEST(render_of_a_frame_scene_is_over_that_frames_shutter)
{
    scene s, fs;
    accel *a = NULL;
    rr_error e;
    shutter sh;
    float px[4];
    const float c[3] = {1, 0.5f, 0.25f};
    CHECK(scene_load_memory(CROSSING_SPHERE, strlen(CROSSING_SPHERE), "mem.xml", ".", &s, &e) == 0);
    CHECK(scene_frame_shutter(&s, 0, &sh, &e) == 0 && scene_for_shutter(&s, &sh, &fs, &e) == 0);
    CHECK(fs.shut.open == 0 && fs.shut.close == 1);
    accel_settings set = {fs.epsilon, fs.kernel_sigma, 1};
    CHECK(accel_build(&fs, &set, &a, &e) == 0 && accel_scene(a) == &fs);
    CHECK(render_pixel(a, px) == 0);
    printf("    frame 0: %g %g %g alpha %g (expected 0)\n", px[0], px[1], px[2], px[3]);
    CHECK(px[0] == 0 && px[1] == 0 && px[2] == 0 && px[3] == 0);
    scene_for_shutter_free(&fs, &s);
    CHECK(scene_frame_shutter(&s, 1, &sh, &e) == 0 && scene_for_shutter(&s, &sh, &fs, &e) == 0);
    CHECK(fs.shut.open == 1 && fs.shut.close == 2 && s.shut.open == 0); /* the file's stays frame 0's */
    CHECK(accel_retime(a, &fs, &e) == 0 && accel_scene(a) == &fs);
    CHECK(render_pixel(a, px) == 0);
    printf("    frame 1: %g %g %g alpha %g (expected c/2, 1/2)\n", px[0], px[1], px[2], px[3]);
    for (int k = 0; k < 3; k++)
        CHECK_NEAR(px[k], 0.5 * c[k], 1e-6);
    CHECK_NEAR(px[3], 0.5, 1e-6);
    scene_for_shutter_free(&fs, &s);
    accel_free(a);
    scene_free(&s);
}

/* render_settings_default is what render.h documents: one batch of one
 * sample per pixel on one thread, every pixel (no shutter: the scene's). */
TEST(render_settings_default_is_one_sample_of_one_batch)
{
    render_settings rs = render_settings_default();
    CHECK(rs.smp.kind == SAMPLER_DEFAULT && rs.smp.seed == 1);
    CHECK(rs.smp.grid == 1 && rs.smp.tspp == 1 && rs.smp.time_factor == 1);
    CHECK(rs.threads == 1 && rs.batch_begin == 0 && rs.batches == 1 && rs.max_batches == 1);
    CHECK(rs.target_error == 0 && rs.integrator == NULL);
    CHECK(rs.crop_x0 == 0 && rs.crop_y0 == 0 && rs.crop_x1 == 0 && rs.crop_y1 == 0);
    CHECK(rs.filter == PIXEL_FILTER_BOX && rs.blur == BLUR_SPACE_MODEL);
}

/* One 3DGS Gaussian in front of the camera at the origin, written to ply. */
static void write_one_gaussian(const char *ply)
{
    gaussian_model m;
    gaussian_model_init(&m);
    m.kind = GAUSSIAN_3D, m.sh_degree = 0, m.sh_coeffs = 1;
    CHECK(gaussian_model_alloc(&m, 1) == 0);
    m.count = 1;
    const float mean[3] = {0.1f, 0, -4}, scale[3] = {0.2f, 0.2f, 0.2f}, rot[4] = {1, 0, 0, 0};
    memcpy(m.mean, mean, sizeof mean), memcpy(m.scale, scale, sizeof scale), memcpy(m.rotation, rot, sizeof rot);
    m.sh[0] = 0.5f, m.sh[1] = 0.2f, m.sh[2] = -0.3f, m.opacity[0] = 0.8f;
    rr_error e;
    CHECK(gaussian_write_ply(ply, &m, &e) == 0);
    gaussian_model_free(&m);
}

/* The traversals of the static objects a render of `xml` makes per pixel
 * batch, with the thesis sampler's 8 times at one raster position (grid 1:
 * a batch is one position); -1 if the scene does not load. */
static double static_traversals_per_batch(const char *xml)
{
    scene s;
    accel *a;
    rr_error e;
    if (scene_load_memory(xml, strlen(xml), "mem.xml", ".", &s, &e)) {
        printf("    %s\n", e.msg);
        return -1;
    }
    accel_settings set = {s.epsilon, s.kernel_sigma, 1};
    CHECK(accel_build(&s, &set, &a, &e) == 0);
    render_settings rs = render_settings_default();
    rs.smp.kind = SAMPLER_THESIS, rs.smp.tspp = 8, rs.smp.time_factor = 2;
    rs.threads = 2, rs.batches = 2;
    image img;
    volatile sig_atomic_t cancel = 0;
    CHECK(image_alloc(&img, 16, 16) == 0 && render_image(a, &rs, &img, NULL, &cancel, &e) == 0);
    CHECK(img.rays == 8u * 2 * 16 * 16);
    double per_batch = (double)img.static_traversals / (2 * 16 * 16);
    image_free(&img);
    accel_free(a);
    scene_free(&s);
    return per_batch;
}

/* Static reuse (thesis sec. 4.5: the samples at one raster position of a
 * still camera share the static objects' hits): the static surfels are
 * traversed once per position, 1 per batch here, not once per sample (8),
 * whether or not the scene also holds a Gaussian object, whose hits each
 * sample composites on its own. A Gaussian object used to send every
 * sample down its own ray (8 per batch). A moving camera traces each
 * sample on its own: 8. */
TEST(render_mixed_scene_keeps_static_reuse_for_its_surfels)
{
    char dir[] = "/tmp/refrender-mixed-XXXXXX", ply[160], xml[1200];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(ply, sizeof ply, "%s/one.ply", dir);
    write_one_gaussian(ply);
    const char *camera = "<camera position='0 0 0' lookat='0 0 -1' up='0 1 0' fov='20' width='16' height='16'>%s</camera>";
    const char *moves = "<animation><linear velocity='0.1 0 0'/></animation>";
    const char *disk = "<object><pointModel><splat center='0 0 -6' normal='0 0 1' radius='3' color='1 0.5 0.25'/>"
                       "</pointModel><material shading='unlit'/></object>";
    const char *mover = "<object><pointModel><splat center='0 0 -5' normal='0 0 1' radius='0.3' color='0 1 0'/>"
                        "</pointModel><animation><linear velocity='0.5 0 0'/></animation></object>";
    char cam[300], still[300];
    snprintf(cam, sizeof cam, camera, moves);
    snprintf(still, sizeof still, camera, "");
    snprintf(xml, sizeof xml, "<scene>%s%s%s</scene>", still, disk, mover);
    CHECK(static_traversals_per_batch(xml) == 1);
    snprintf(xml, sizeof xml, "<scene>%s%s%s<object><gaussianModel file='%s' kind='3dgs'/></object></scene>", still,
             disk, mover, ply);
    double mixed = static_traversals_per_batch(xml);
    if (mixed != 1)
        printf("    surfels and a Gaussian, still camera: %g static traversals per batch (want 1)\n", mixed);
    CHECK(mixed == 1);
    snprintf(xml, sizeof xml, "<scene>%s%s%s<object><gaussianModel file='%s' kind='3dgs'/></object></scene>", cam,
             disk, mover, ply);
    CHECK(static_traversals_per_batch(xml) == 8);
    unlink(ply);
    rmdir(dir);
}
