/* shade.c: blending with the kernel weights, then Phong of the blend
 * (thesis sec. 4.5 step c), against values worked by hand. */
#include <string.h>

#include "harness.h"
#include "scenexml/scene_xml.h"
#include "scene/shade.h"

/* Object 0 unlit, object 1 Phong (diffuse 0.5, specular 0.25, shininess 2);
 * ambient 0.1; one directional light of color (1, 0.5, 0.25) travelling
 * along -z (towards a surface facing +z). */
static const char *const XML =
    "<scene><ambient color='0.1 0.1 0.1'/><light type='directional' direction='0 0 -1' color='1 0.5 0.25'/>"
    "<object><sphere radius='1'/><material shading='unlit'/></object>"
    "<object><sphere radius='1'/><material shading='phong' diffuse='0.5' specular='0.25' shininess='2'/></object>"
    "</scene>";

static surface_hit hit(float t, unsigned obj, float weight, vec3 color, vec3 normal)
{
    surface_hit h;
    memset(&h, 0, sizeof h);
    h.t = t, h.obj = obj, h.weight = weight;
    h.color[0] = (float)color.x, h.color[1] = (float)color.y, h.color[2] = (float)color.z;
    h.normal[0] = (float)normal.x, h.normal[1] = (float)normal.y, h.normal[2] = (float)normal.z;
    return h;
}

/* The colour of the n hits blended in one k-buffer, seen by a viewer at
 * z = 5 looking along -z (towards surfaces facing +z). */
static vec3 shade_seen_from_above(const scene *s, int n, const surface_hit *h)
{
    kbuffer kb;
    kbuffer_reset(&kb, 0.5f);
    for (int i = 0; i < n; i++)
        kbuffer_insert(&kb, &h[i]);
    return shade_hits(s, &kb, v3(0, 0, 5), v3(0, 0, -1));
}

static int load(const char *xml, scene *s)
{
    rr_error e;
    return scene_load_memory(xml, strlen(xml), "mem.xml", ".", s, &e);
}

TEST(unlit_blend_is_the_kernel_weighted_mean_color)
{
    scene s;
    CHECK(load(XML, &s) == 0);
    surface_hit h[2] = {hit(2.0f, 0, 0.75f, v3(1, 0, 0), v3(0, 0, 1)), hit(2.1f, 0, 0.25f, v3(0, 0, 1), v3(0, 0, 1))};
    vec3 c = shade_seen_from_above(&s, 2, h);
    CHECK_NEAR(c.x, 0.75, 1e-7);
    CHECK_NEAR(c.y, 0, 0);
    CHECK_NEAR(c.z, 0.25, 1e-7);
    scene_free(&s);
}

TEST(phong_of_a_surface_facing_the_light_and_the_viewer)
{
    scene s;
    CHECK(load(XML, &s) == 0);
    /* n = l = v = +z: n.l = 1, r.v = 1; color C = (0.8, 0.6, 0.4), kd = 0.5 C:
     * ambient kd * 0.1 + L * (kd * 1 + 0.25 * 1^2) */
    surface_hit h[1] = {hit(2.0f, 1, 1.0f, v3(0.8, 0.6, 0.4), v3(0, 0, 1))};
    vec3 c = shade_seen_from_above(&s, 1, h);
    CHECK_NEAR(c.x, 0.4 * 0.1 + 1.0 * (0.4 + 0.25), 1e-6);
    CHECK_NEAR(c.y, 0.3 * 0.1 + 0.5 * (0.3 + 0.25), 1e-6);
    CHECK_NEAR(c.z, 0.2 * 0.1 + 0.25 * (0.2 + 0.25), 1e-6);
    /* facing away from the light (n.l < 0): ambient only, no specular */
    surface_hit back[1] = {hit(2.0f, 1, 1.0f, v3(0.8, 0.6, 0.4), v3(0, 0, -1))};
    c = shade_seen_from_above(&s, 1, back);
    CHECK_NEAR(c.x, 0.04, 1e-6);
    CHECK_NEAR(c.z, 0.02, 1e-6);
    scene_free(&s);
}

TEST(mixed_materials_blend_lit_and_unlit_by_weight)
{
    scene s;
    CHECK(load(XML, &s) == 0);
    surface_hit lit[1] = {hit(2.0f, 1, 1.0f, v3(1, 1, 1), v3(0, 0, 1))};
    surface_hit unlit[1] = {hit(2.0f, 0, 1.0f, v3(1, 1, 1), v3(0, 0, 1))};
    vec3 ca = shade_seen_from_above(&s, 1, lit), cb = shade_seen_from_above(&s, 1, unlit);
    surface_hit both[2] = {hit(2.0f, 1, 0.5f, v3(1, 1, 1), v3(0, 0, 1)), hit(2.0f, 0, 0.5f, v3(1, 1, 1), v3(0, 0, 1))};
    vec3 c = shade_seen_from_above(&s, 2, both);
    /* half the weight lit: the mean of the two (material parameters averaged too:
     * diffuse 0.75, specular 0.125, shininess 17 -> worked through below) */
    double kd = 0.5 * (0.5 + 1.0), spec = 0.5 * 0.25;
    double lit_x = kd * 0.1 + 1.0 * (kd + spec);
    CHECK_NEAR(c.x, 0.5 * lit_x + 0.5 * 1.0, 1e-6);
    CHECK(ca.x != cb.x);
    scene_free(&s);
}

/* The shininess exponent: light 60 degrees off the normal, viewer along it,
 * so n.l = cos 60 = 0.5 and the mirrored light r = 2 (n.l) n - l makes
 * r.v = 0.5 too (the case above has r.v = 1, where any exponent gives 1).
 * Specular 0.25 * 0.5^2 = 0.0625 (0.125 if the exponent were ignored). */
TEST(phong_specular_follows_the_shininess_exponent)
{
    static const char *const OBLIQUE =
        "<scene><ambient color='0.1 0.1 0.1'/>"
        "<light type='directional' direction='-0.86602540378443865 0 -0.5' color='1 1 1'/>"
        "<object><sphere radius='1'/><material shading='phong' diffuse='0.5' specular='0.25' shininess='2'/>"
        "</object></scene>";
    scene s;
    CHECK(load(OBLIQUE, &s) == 0);
    surface_hit h[1] = {hit(2.0f, 0, 1.0f, v3(0.8, 0.6, 0.4), v3(0, 0, 1))};
    vec3 c = shade_seen_from_above(&s, 1, h);
    CHECK_NEAR(c.x, 0.4 * 0.1 + 0.4 * 0.5 + 0.0625, 1e-6);
    CHECK_NEAR(c.y, 0.3 * 0.1 + 0.3 * 0.5 + 0.0625, 1e-6);
    CHECK_NEAR(c.z, 0.2 * 0.1 + 0.2 * 0.5 + 0.0625, 1e-6);
    scene_free(&s);
}
