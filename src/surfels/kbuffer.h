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
    float dropped_t; /* the nearest hit that found no room (INFINITY: none); whether
                        it lies within epsilon of the final closest hit is what
                        kbuffer_overflowed decides, after the traversal */
    float closest, epsilon;
    surface_hit hits[KBUFFER_MAX]; /* sorted by (t, obj, prim) */
} kbuffer;

/* The epsilon rule (thesis sec. 4.1.1: the visibility pass shifts depths
 * by epsilon along the viewing ray; sec. 4.5 step c): a hit at depth t
 * blends with the closest one when t <= closest + epsilon, in float as the
 * buffer holds them. One owner for the ray tracer and src/splatting/. */
static inline int kbuffer_within(float t, float closest, float epsilon)
{
    return t <= closest + epsilon;
}

void kbuffer_reset(kbuffer *kb, float epsilon);
/* Inserts a hit if it lies within epsilon of the closest so far. */
void kbuffer_insert(kbuffer *kb, const surface_hit *h);

/* Did more than KBUFFER_MAX hits lie within epsilon of the closest? Decided
 * from the final closest hit, so it does not depend on the order the hits
 * came in (a hit dropped while the window was wider, before a nearer hit
 * arrived, may lie beyond the final window: that is no overflow). Every
 * dropped hit comes after every kept one in (t, obj, prim) order, so when
 * the hits within the final window number more than KBUFFER_MAX the
 * nearest dropped one is the first of them that did not fit. */
int kbuffer_overflowed(const kbuffer *kb);

/* The farthest distance a ray still needs to reach: just past closest +
 * epsilon (the window is closed). */
float kbuffer_cutoff(const kbuffer *kb);

#endif
