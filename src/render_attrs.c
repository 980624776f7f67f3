#include "render_attrs.h"

#include <inttypes.h>
#include <stdio.h>

static void describe_weight(const shutter *sh, char *buf, size_t size)
{
    if (sh->kind == WEIGHT_LINEAR)
        snprintf(buf, size, "linear center=%.17g", sh->center);
    else if (sh->kind == WEIGHT_EXP)
        snprintf(buf, size, "exp center=%.17g rate=%.17g", sh->center, sh->rate);
    else if (sh->kind == WEIGHT_TABLE) {
        size_t len = (size_t)snprintf(buf, size, "table");
        for (int i = 0; i < sh->table_size && len < size; i++)
            len += (size_t)snprintf(buf + len, size - len, " %.17g %.17g", sh->table_t[i], sh->table_w[i]);
    } else
        snprintf(buf, size, "box");
}

void attrs_for_render(attr_list *a, const scene *s, const render_settings *rs, uint32_t total_batches,
                      const char *command)
{
    char weight[4096];
    describe_weight(&rs->shut, weight, sizeof weight);
    const sampler *smp = &rs->smp;
    attrs_set(a, "refrender:scene", "%s", s->path);
    attrs_set(a, "refrender:sceneHash", "%016" PRIx64, s->scene_hash);
    attrs_set(a, "refrender:inputsHash", "%016" PRIx64, s->inputs_hash);
    attrs_set(a, "refrender:resolution", "%dx%d", s->cam.width, s->cam.height);
    attrs_set(a, "refrender:sampler", "%s", sampler_name(smp->kind));
    attrs_set(a, "refrender:spp", "%d", smp->grid * smp->grid);
    attrs_set(a, "refrender:tspp", "%d", smp->tspp);
    attrs_set(a, "refrender:seed", "%" PRIu64, smp->seed);
    attrs_set(a, "refrender:epsilon", "%.17g", s->epsilon);
    attrs_set(a, "refrender:kernelSigma", "%.17g", s->kernel_sigma);
    attrs_set(a, "refrender:shutter", "%.17g %.17g", rs->shut.open, rs->shut.close);
    attrs_set(a, "refrender:weightFunction", "%s", weight);
    attrs_set(a, "refrender:timeFactor", "%d", smp->time_factor);
    attrs_set(a, "refrender:timeIntegration", "%s", rs->exact_time ? "exact" : "sampled");
    /* the convention compare.py --alpha composite relies on (README, Output) */
    attrs_set(a, "refrender:background", "%.9g %.9g %.9g", s->background.x, s->background.y, s->background.z);
    attrs_set(a, "refrender:alpha", "coverage; RGB already holds refrender:background where coverage < 1");
    attrs_set(a, "refrender:batches", "%u", total_batches);
    attrs_set(a, "refrender:command", "%s", command);
    attrs_set(a, "software", "refrender %s", RR_VERSION);
}

