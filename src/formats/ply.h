/* Surfel PLY files (ascii, binary_little_endian, binary_big_endian).
 *
 * Vertex properties read (any scalar type; others are ignored):
 *   x y z                    position, required
 *   nx ny nz                 shading normal
 *   radius                   circular splat radius (needs nx ny nz)
 *   ux uy uz vx vy vz        elliptical splat: tangent axes scaled to the
 *                            principal radii (take precedence over radius)
 *   red green blue           color; integer types are divided by their
 *                            maximum (255 for uchar), float types taken as is
 * A vertex without a splat size is an error: ray tracing needs a surface
 * extent, and guessing one would silently change the reference image. */
#ifndef RR_PLY_H
#define RR_PLY_H

#include "core/inputfile.h"
#include "surfels/pointmodel.h"
#include "surfels/surfel.h"

#include <stdint.h>

/* Largest PLY file read (bytes): about 100M splats of 13 floats and a color. */
#define PLY_MAX_BYTES ((size_t)1 << 33)

/* Appends every vertex of the PLY file to m. default_color is used when the
 * file has no colors. In ascii files each element is one line (PLY 1.0): a
 * line with fewer or more values than its properties declare is an error.
 * The file's bytes are folded into *content_hash unless it is NULL
 * (inputfile.h). Errors name the file and the header line, ascii line, or
 * binary vertex index. A non-zero *cancel (NULL: never) stops the read
 * within 65536 vertices ("interrupted while reading vertex i of n"):
 * a command's interrupt flag, so that a signal need not wait for a model
 * of gigabytes. */
int ply_read(const char *path, vec3 default_color, pointmodel *m, uint64_t *content_hash, volatile sig_atomic_t *cancel,
             rr_error *err);

/* The same from len bytes in memory; name is used in messages. */
int ply_parse(const char *name, const char *data, size_t len, vec3 default_color, pointmodel *m, rr_error *err);

/* The reader's generic layer, shared by the surfel reader above and the
 * Gaussian-splat reader (gaussian.c): vertex properties are found by name
 * (any order, any scalar type; others are skipped), a name declared twice
 * is an error naming it, and the declared count is checked against the
 * file's size before anything is read. */
/* Slots: a converted 4DGS model has 163 properties (degree-3 SH with two
 * time harmonics); the reader's per-vertex arrays of this size are on the
 * stack (3 KB). */
#define PLY_MAX_SLOTS 256
/* Properties of one element: 3DGS models have 62 (degree-3 SH), and
 * trainers add their own. */
#define PLY_MAX_PROPERTIES 256
typedef struct {
    const char *const *names; /* the slots: vertex property names */
    int count;                /* at most PLY_MAX_SLOTS */
    int scale_ints_from;      /* slots from here on divide integer values by their type's maximum */
} ply_schema;

typedef struct {
    /* the declared slots (present[slot] = 1) and vertex count, before any
     * vertex is read: -1 (with err filled, naming path) refuses the file */
    int (*begin)(void *user, const char *path, const int *present, size_t count, rr_error *err);
    /* one vertex's slot values (0 where absent): -1 with a reason refuses
     * it (the reader adds the file and the vertex's line or index) */
    int (*vertex)(void *user, const double *vals, const int *present, char *why, size_t why_size);
    void *user;
    /* optional (NULL: none): each vertex property's name with its header
     * line, as the header declares it, schema or not: -1 (with err filled,
     * naming path and line) refuses the file. Lets a reader see what its
     * schema cannot hold (properties it must refuse, runs of any length). */
    int (*property)(void *user, const char *path, long line, const char *name, rr_error *err);
} ply_visitor;

int ply_parse_vertices(const char *name, const char *data, size_t len, const ply_schema *schema,
                       const ply_visitor *v, rr_error *err);
/* The same from a file (inputfile.h: at most PLY_MAX_BYTES), its bytes
 * folded into *content_hash unless it is NULL, stopped by *cancel as
 * ply_read. */
int ply_read_vertices(const char *path, const ply_schema *schema, const ply_visitor *v, uint64_t *content_hash,
                      volatile sig_atomic_t *cancel, rr_error *err);
/* The same from a file already opened (input_file_stream), which the parse
 * releases as it reads (input_file_consume): a reader that must look at a
 * file twice (gaussian_ply.c hands a dynamic model's file on) opens and
 * hashes it once; src->cancel stops it. (A parse from memory has no stop
 * flag: only files are large enough to need one.) */
int ply_stream_vertices(const char *name, input_file *src, const ply_schema *schema, const ply_visitor *v,
                        rr_error *err);

/* Writes circular surfels as binary little-endian PLY with float x y z nx ny
 * nz radius and uchar red green blue (the generator's output format). */
int ply_write_surfels(const char *path, const surfel *s, size_t n, rr_error *err);

#endif
