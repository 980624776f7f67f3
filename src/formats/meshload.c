#include "formats/meshload.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Every mesh of the file, concatenated. */
int meshload_mesh(const char *path, double **pos, double **nrm, size_t *nv, unsigned **tri, size_t *nt,
                  rr_error *err)
{
    const struct aiScene *sc = aiImportFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                                      aiProcess_GenSmoothNormals | aiProcess_PreTransformVertices);
    if (!sc)
        return rr_fail(err, "%s: %s", path, aiGetErrorString());
    size_t v = 0, t = 0;
    for (unsigned m = 0; m < sc->mNumMeshes; m++)
        v += sc->mMeshes[m]->mNumVertices, t += sc->mMeshes[m]->mNumFaces;
    *pos = malloc((v + 1) * 3 * sizeof **pos), *nrm = calloc((v + 1) * 3, sizeof **nrm);
    *tri = malloc((t + 1) * 3 * sizeof **tri);
    if (!*pos || !*nrm || !*tri) {
        aiReleaseImport(sc);
        return rr_fail(err, "%s: out of memory", path);
    }
    size_t vbase = 0, tcount = 0;
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        const struct aiMesh *mesh = sc->mMeshes[m];
        for (unsigned i = 0; i < mesh->mNumVertices; i++) {
            const struct aiVector3D *p = &mesh->mVertices[i];
            double *dp = &(*pos)[3 * (vbase + i)], *dn = &(*nrm)[3 * (vbase + i)];
            dp[0] = p->x, dp[1] = p->y, dp[2] = p->z;
            if (mesh->mNormals)
                dn[0] = mesh->mNormals[i].x, dn[1] = mesh->mNormals[i].y, dn[2] = mesh->mNormals[i].z;
        }
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            const struct aiFace *face = &mesh->mFaces[f];
            if (face->mNumIndices != 3)
                continue; /* points and lines carry no area */
            for (int k = 0; k < 3; k++)
                (*tri)[3 * tcount + k] = (unsigned)(vbase + face->mIndices[k]);
            tcount++;
        }
        vbase += mesh->mNumVertices;
    }
    aiReleaseImport(sc);
    *nv = vbase, *nt = tcount;
    return 0;
}

static int has_suffix(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcasecmp(s + a - b, suffix);
}

/* x y z nx ny nz per line; '#' starts a comment. */
int meshload_points(const char *path, double **pos, double **nrm, size_t *np, rr_error *err)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return rr_fail(err, "%s: cannot open", path);
    size_t pos_cap = 0, nrm_cap = 0, n = 0;
    *pos = NULL, *nrm = NULL;
    char line[1024];
    int lineno = 0, rc = 0;
    while (!rc && fgets(line, sizeof line, f)) {
        lineno++;
        char *hash = strchr(line, '#');
        if (hash)
            *hash = 0;
        double v[6];
        char extra;
        int got = sscanf(line, "%lf %lf %lf %lf %lf %lf %c", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &extra);
        if (got == EOF || got == -1)
            continue;
        int finite = 1;
        for (int k = 0; k < got && k < 6; k++)
            finite &= isfinite(v[k]);
        if (got != 6 || !finite) {
            rc = rr_fail(err, "%s:%d: expected six finite numbers (x y z nx ny nz)", path, lineno);
            break;
        }
        if (rr_grow((void **)pos, &pos_cap, n + 1, 3 * sizeof **pos) ||
            rr_grow((void **)nrm, &nrm_cap, n + 1, 3 * sizeof **nrm)) {
            rc = rr_fail(err, "%s: out of memory", path);
            break;
        }
        memcpy(&(*pos)[3 * n], v, 3 * sizeof *v);
        memcpy(&(*nrm)[3 * n], v + 3, 3 * sizeof *v);
        n++;
    }
    fclose(f);
    *np = n;
    return rc;
}

int meshload_is_point_cloud(const char *path) { return has_suffix(path, ".xyz") || has_suffix(path, ".pts"); }
