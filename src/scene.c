#include "scene.h"

#include <stdlib.h>
#include <string.h>

void scene_init(scene *s)
{
    memset(s, 0, sizeof *s);
    s->cam.position = v3(0, 0, 5);
    s->cam.lookat = v3(0, 0, 0);
    s->cam.up = v3(0, 1, 0);
    s->cam.fov_degrees = 45.0;
    s->cam.width = 512;
    s->cam.height = 512;
    shutter_default(&s->shut);
    s->background = v3(0, 0, 0);
    s->ambient = v3(0, 0, 0);
    s->epsilon = 0.01;
    s->kernel_sigma = 0.5;
    s->time_factor = 4;
}

void scene_free(scene *s)
{
    for (int i = 0; i < s->nobjects; i++)
        pointmodel_free(&s->objects[i].model);
    free(s->objects);
    free(s->lights);
    s->objects = NULL;
    s->lights = NULL;
    s->nobjects = s->nlights = 0;
}

aabb scene_object_bounds(const scene_object *o)
{
    if (o->kind == OBJECT_POINTS)
        return o->model.bounds;
    vec3 r = v3(o->sphere_radius, o->sphere_radius, o->sphere_radius);
    aabb b = {v3_sub(o->sphere_center, r), v3_add(o->sphere_center, r)};
    return b;
}
