/* The epsilon-blending hit set of one ray (thesis sec. 4.5 step c): a
 * small buffer of the hits within epsilon of the closest, kept sorted by
 * (t, object, splat) so that the set and its order do not depend on the
 * order in which a traversal offers the hits. Pure data; no Embree. */
#ifndef RR_KBUFFER_H
#define RR_KBUFFER_H

#define KBUFFER_MAX 64

typedef struct {
    float t;
    unsigned obj, prim;
    float weight;    /* kernel weight (1 for analytic spheres) */
    float r2;        /* squared kernel radius; the weight is computed from it
                        only for the hits that stay in the buffer */
    float color[3];
    float normal[3]; /* world space, facing the ray origin */
} surface_hit;

typedef struct {
    int count;
    int dropped;     /* hits beyond KBUFFER_MAX within epsilon (farthest dropped) */
    float closest, epsilon;
    surface_hit hits[KBUFFER_MAX]; /* sorted by (t, obj, prim) */
} kbuffer;

/* The epsilon rule (thesis sec. 4.1.1: the visibility pass shifts depths
 * by epsilon along the viewing ray; sec. 4.5 step c): a hit at depth t
 * blends with the closest one when t <= closest + epsilon, in float as the
 * buffer holds them. One owner for the ray tracer and src/splat/. */
static inline int kbuffer_within(float t, float closest, float epsilon)
{
    return t <= closest + epsilon;
}

void kbuffer_reset(kbuffer *kb, float epsilon);
/* Inserts a hit if it lies within epsilon of the closest so far. */
void kbuffer_insert(kbuffer *kb, const surface_hit *h);

/* The farthest distance a ray still needs to reach: just past closest +
 * epsilon (the window is closed). */
float kbuffer_cutoff(const kbuffer *kb);

#endif
