/* A camera trajectory: knot poses at times, interpolated as the
 * deblurring methods that exchange trajectory files do. This is the
 * interpolation maths only; the files are read by tum.h (TUM text) and
 * transforms.h (nerfstudio's transforms.json), which fill a trajectory.
 *
 * Knots are camera-to-world poses: position p and unit quaternion q
 * (w, x, y, z) of the rotation whose columns are the camera's axes in
 * world space, in the file's axis convention (OpenGL: x right, y up, z
 * backward, as BAD-Gaussians' TUM export writes; OpenCV: x right, y down,
 * z forward). trajectory_pose returns OpenCV axes, the renderer's rest
 * camera frame (camera.h, camera_view).
 *
 * Interpolations (u is the fraction of the segment or span; the rules,
 * with their sources' commits and lines, are in src/TRAJECTORIES.md):
 *   linear      per segment: p lerped, q_k Exp(u Log(q_k^-1 q_k+1)), the
 *               short arc (split R^3 x SO(3); BAD-Gaussians "linear")
 *   se3         per segment: T_k Exp(u Log(T_k^-1 T_k+1)), a screw motion
 *               (DeblurGS "se3")
 *   cubic       uniform cubic B-spline over knots k-1..k+2 on [t_k, t_k+1]
 *               (defined on [t_1, t_n-2]); p with the B-spline weights, the
 *               rotation cumulative: R_k-1 Exp(B1 L1) Exp(B2 L2) Exp(B3 L3),
 *               L_j = Log(R_k-2+j^-1 R_k-1+j) (BAD-Gaussians "cubic")
 *   bezier      all knots as control points over [t_0, t_n-1]: p and q
 *               blended per component (q signs aligned), q normalised
 *   bezier-se3  Exp(sum_i b_i(u) Log T_i) of the absolute poses in the
 *               file's axes (DeblurGS)
 *   gsplat      per segment: the world-to-camera translation -R^T p lerped,
 *               q as linear's (gsplat's rolling-shutter pose, v1.5.3
 *               Cameras.cuh:276-288); no file names it: a frame under
 *               rolling="gsplat" moves its camera so (scene_for_shutter)
 */
#ifndef RR_TRAJECTORY_H
#define RR_TRAJECTORY_H

#include "core/common.h"

typedef enum {
    TRAJECTORY_LINEAR,
    TRAJECTORY_SE3,
    TRAJECTORY_CUBIC,
    TRAJECTORY_BEZIER,
    TRAJECTORY_BEZIER_SE3,
    TRAJECTORY_GSPLAT, /* not read from files: scene_for_shutter's, rolling="gsplat" */
} trajectory_interp;

typedef struct {
    double t;
    vec3 p;
    double q[4]; /* w, x, y, z; unit to 1e-14 */
} trajectory_knot;

typedef struct trajectory { /* (animation.h names it to hold one) */
    trajectory_interp interp;
    int opengl_axes; /* the file's camera axes: 1 OpenGL, 0 OpenCV */
    int count;
    trajectory_knot *knots;
    long *lines; /* the TUM line each knot was read from, for messages
                  * (NULL: a transforms.json's, knot k its frames[k]) */
    /* over the whole domain, set by trajectory_prepare: how fast the
     * camera's origin moves and how fast it turns (radians) per unit time */
    double speed, turn_rate;
    char *name; /* the file, for messages (tum_load) */
} trajectory;

/* Control poses a Bezier may have (BAD-Gaussians uses up to about 10). */
#define TRAJECTORY_MAX_BEZIER 32

/* "linear", "se3", "cubic", "bezier", "bezier-se3"; -1 if unknown (also
 * "gsplat": no file names it). */
int trajectory_interp_parse(const char *name);
const char *trajectory_interp_name(trajectory_interp k);
/* Knots the interpolation needs at least. */
int trajectory_min_knots(trajectory_interp k);

/* Checks the knots against the interpolation (how many; cubic: evenly
 * spaced; bezier: control quaternions within one hemisphere; every
 * rotation between neighbours short of 180 degrees, where Log is
 * ambiguous; times far enough apart that the motion bounds are finite)
 * and sets the motion bounds. Fails naming name and, where one pose is
 * at fault, its line (or frames[k]). */
int trajectory_prepare(trajectory *tr, const char *name, rr_error *err);

/* The times the interpolation is defined over. */
void trajectory_domain(const trajectory *tr, double *t0, double *t1);

/* The pose at time t (clamped to the domain), OpenCV camera axes. */
void trajectory_pose(const trajectory *tr, double t, vec3 *p, double q[4]);

/* An OpenCV-axes rotation q in the given axes (OpenGL: R diag(1, -1, -1)). */
void trajectory_quat_to_axes(const double q[4], double out[4], int opengl_axes);

void trajectory_free(trajectory *tr);

#endif
