/* The table of dynamic models' PLY readers (gaussian_dynamic_ply.h). */
#include "formats/gaussian_dynamic_ply.h"

#include <stddef.h>

const gaussian_dynamic_ply_reader *const gaussian_dynamic_ply_readers[] = {
    &gaussian_stg_ply,
    &gaussian_fdgs_ply,
    NULL,
};

const gaussian_dynamic_ply_reader *gaussian_dynamic_ply_claimant(const char *name)
{
    for (int k = 0; gaussian_dynamic_ply_readers[k]; k++)
        if (gaussian_dynamic_ply_readers[k]->claims(name))
            return gaussian_dynamic_ply_readers[k];
    return NULL;
}

int gaussian_dynamic_ply_refuse_other(const gaussian_dynamic_ply_reader *self, const char *path, long line,
                                      const char *name, rr_error *err)
{
    const gaussian_dynamic_ply_reader *other = gaussian_dynamic_ply_claimant(name);
    if (!other || other == self)
        return 0;
    return rr_fail(err, "%s:%ld: vertex property '%s' is %s beside %s ones (%s): a layout mixing the two is refused",
                   path, line, name, other->possessive, self->layout, self->own);
}
