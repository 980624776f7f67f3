/* An integrator's own counters (issue 57): each row of the integrator
 * table (integrator.h) declares a short list of them; the render loop sums
 * them over batches and threads into the image (film.h), and the header
 * writes each as its attribute (io/output.h, output_counter_attrs), none of
 * the three knowing what a counter means; a checkpoint's header holds them
 * too, and a resumed render reads them back (render_frames.c). Exact
 * time's share of the shutter left uncertified (exact.h) is one. */
#ifndef RR_COUNTERS_H
#define RR_COUNTERS_H

/* Most counters a row may declare. */
enum { COUNTERS_MAX = 4 };

/* How a counter's sum becomes its header value (output_counter_value). */
typedef enum {
    /* the sum over (rays traced x the shutter's length): a share of the
     * shutter per traced ray, written to 6 digits; the states of a merge
     * give their ray-weighted mean (output.c's ROLE_PER_RAY) */
    COUNTER_SHARE_PER_RAY,
} counter_scale;

typedef struct {
    const char *attribute; /* its EXR header attribute (a row of output.c's attr_table, to be merged) */
    counter_scale scale;
    /* The row's warning on stderr about the header value, if that value
     * calls for one (not with --quiet); NULL: never. */
    void (*warn)(double value);
} counter_spec;

/* The counters of a render: the row's specs and their sums (by index). */
typedef struct {
    const counter_spec *spec; /* NULL before a render, or when the row declares none */
    int n;
    double sum[COUNTERS_MAX];
} counter_set;

#endif
