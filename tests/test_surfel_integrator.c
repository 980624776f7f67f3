/* surfel_integrator.c: the epsilon window, blending and Phong of a given
 * list of hits, with no traversal (surfel_hits_rgba), against values
 * worked by hand. */
#include <string.h>

#include "harness.h"
#include "scenexml/scene_xml.h"
#include "render/surfel_integrator.h"

/* Two unlit objects in front of a grey background. */
static const char *const XML = "<scene><background color='0.5 0.5 0.5'/>"
                               "<object><sphere radius='1'/><material shading='unlit'/></object>"
                               "<object><sphere radius='1'/><material shading='unlit'/></object></scene>";

static surface_hit hit(float t, unsigned obj, unsigned prim, float weight, float r, float g, float b)
{
    surface_hit h;
    memset(&h, 0, sizeof h);
    h.t = t, h.obj = obj, h.prim = prim, h.weight = weight;
    h.color[0] = r, h.color[1] = g, h.color[2] = b;
    h.normal[2] = 1;
    return h;
}

/* Epsilon 0.25 (exact in float): the hits at 2 and 2.125 blend (2.125 <=
 * 2 + 0.25), those at 2.5 and 5 lie beyond the window. The blend is the
 * kernel-weighted mean (weights 1 and 3: (1 red + 3 blue) / 4), coverage
 * 1, whatever order the hits come in; no hit is the background, coverage
 * 0. */
TEST(surfel_hits_rgba_blends_the_window_of_a_list_in_any_order)
{
    scene s;
    rr_error e;
    CHECK(scene_load_memory(XML, strlen(XML), "mem.xml", ".", &s, &e) == 0);
    surface_hit h[4] = {hit(5.0f, 0, 0, 1, 0, 1, 0), hit(2.125f, 1, 0, 3, 0, 0, 1), hit(2.5f, 0, 1, 1, 0, 1, 0),
                        hit(2.0f, 0, 2, 1, 1, 0, 0)};
    const int orders[3][4] = {{0, 1, 2, 3}, {3, 2, 1, 0}, {2, 0, 3, 1}};
    for (int o = 0; o < 3; o++) {
        surface_hit list[4];
        for (int i = 0; i < 4; i++)
            list[i] = h[orders[o][i]];
        double rgba[4];
        CHECK(surfel_hits_rgba(&s, list, 4, 0.25f, v3(0, 0, 5), v3(0, 0, -1), rgba) == 0);
        CHECK(rgba[0] == 0.25 && rgba[1] == 0 && rgba[2] == 0.75 && rgba[3] == 1);
    }
    double rgba[4];
    CHECK(surfel_hits_rgba(&s, h, 0, 0.25f, v3(0, 0, 5), v3(0, 0, -1), rgba) == 0);
    CHECK(rgba[0] == 0.5 && rgba[1] == 0.5 && rgba[2] == 0.5 && rgba[3] == 0);
    scene_free(&s);
}

/* KBUFFER_MAX + 1 hits at one depth all lie within the window: one finds
 * no room, which is an overflow; KBUFFER_MAX of them are not. */
TEST(surfel_hits_rgba_reports_a_window_past_the_kbuffer)
{
    scene s;
    rr_error e;
    CHECK(scene_load_memory(XML, strlen(XML), "mem.xml", ".", &s, &e) == 0);
    surface_hit h[KBUFFER_MAX + 1];
    for (unsigned i = 0; i <= KBUFFER_MAX; i++)
        h[i] = hit(3.0f, 0, i, 1, 0.5f, 0.25f, 1);
    double rgba[4];
    CHECK(surfel_hits_rgba(&s, h, KBUFFER_MAX, 0.25f, v3(0, 0, 5), v3(0, 0, -1), rgba) == 0);
    CHECK(rgba[0] == 0.5 && rgba[1] == 0.25 && rgba[2] == 1 && rgba[3] == 1);
    CHECK(surfel_hits_rgba(&s, h, KBUFFER_MAX + 1, 0.25f, v3(0, 0, 5), v3(0, 0, -1), rgba) == 1);
    scene_free(&s);
}
