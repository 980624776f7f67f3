#include "formats/camsource.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

camsource_kind camsource_kind_of(const char *path)
{
    struct stat st;
    size_t n = strlen(path);
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return CAMSOURCE_COLMAP;
    return n >= 4 && !strcmp(path + n - 4, ".npy") ? CAMSOURCE_LLFF : CAMSOURCE_JSON;
}

static int llff_dir(const char *path, camsource *s, rr_error *err)
{
    const char *slash = strrchr(path, '/');
    s->dir = slash ? strndup(path, (size_t)(slash - path + 1)) : strdup("");
    return s->dir ? 0 : rr_fail(err, "out of memory");
}

int camsource_load(const char *path, camsource *s, uint64_t *content_hash, rr_error *err)
{
    memset(s, 0, sizeof *s);
    s->kind = camsource_kind_of(path);
    int rc;
    switch (s->kind) {
    case CAMSOURCE_COLMAP:
        return colmap_load(path, &s->colmap, content_hash, s->files, err);
    case CAMSOURCE_LLFF:
        rc = llff_load(path, &s->llff, content_hash, err) || llff_dir(path, s, err);
        break;
    default:
        rc = camjson_load(path, &s->json, content_hash, err);
        break;
    }
    if (!rc && !(s->files[0] = strdup(path)))
        rc = rr_fail(err, "out of memory");
    if (rc)
        camsource_free(s);
    return rc;
}

static int llff_named(camsource *s, const char *image, camjson_camera *out, uint64_t *content_hash, rr_error *err)
{
    if (!s->llff.image_names) {
        char *images = NULL;
        if (asprintf(&images, "%simages", s->dir) < 0)
            return rr_fail(err, "out of memory");
        int rc = llff_list_images(&s->llff, images, content_hash, err);
        free(images);
        if (rc)
            return -1;
    }
    return llff_find(&s->llff, image, -1, out, err);
}

int camsource_find(camsource *s, camsource_key key, camjson_camera *out, uint64_t *content_hash, rr_error *err)
{
    switch (s->kind) {
    case CAMSOURCE_COLMAP:
        return colmap_find(&s->colmap, key.image, key.image ? -1 : key.number, out, err);
    case CAMSOURCE_LLFF:
        return key.image ? llff_named(s, key.image, out, content_hash, err)
                         : llff_find(&s->llff, NULL, key.number, out, err);
    default:
        return camjson_find(&s->json, key.image, out, err);
    }
}

void camsource_free(camsource *s)
{
    if (s->kind == CAMSOURCE_COLMAP)
        colmap_free(&s->colmap);
    else if (s->kind == CAMSOURCE_LLFF)
        llff_free(&s->llff);
    else if (s->json.root)
        camjson_free(&s->json);
    free(s->dir);
    free(s->files[0]);
    free(s->files[1]);
    memset(s, 0, sizeof *s);
}
