/*
 * Small float linear algebra for the pose module: a bounded one-sided Jacobi
 * SVD of 3x3 matrices, the weighted absolute-orientation solution of the
 * paper's §5.1 (Arun/Kabsch with the reflection guard), and the image of a
 * circle's centre under perspective.
 */
#ifndef POSE_POSE_LINALG_H
#define POSE_POSE_LINALG_H

#include <stddef.h>

#include "pose/pose_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Sweep bound of the Jacobi SVD; 3x3 matrices converge in 4-6 sweeps in float. */
#define POSE_SVD_MAX_SWEEPS 16

/*
 * Singular value decomposition a = u * diag(s) * v^T with s[0] >= s[1] >= s[2] >= 0
 * and u, v orthonormal (det may be -1). Returns the number of sweeps used (> 0) or
 * POSE_ERR_NO_CONVERGE if POSE_SVD_MAX_SWEEPS did not suffice (outputs still filled).
 */
int pose_svd3(const float a[3][3], float u[3][3], float s[3], float v[3][3]);

/*
 * Weighted absolute orientation (paper §5.1, Eqs. 38-46): the proper rotation r
 * and translation t minimising sum_i w[i] * |r * model[i] + t - observed[i]|^2.
 * w may be NULL (all weights 1); weights must be >= 0 with a positive sum.
 * Returns POSE_OK, POSE_ERR_INVALID (n < 3, bad weights) or POSE_ERR_DEGENERATE
 * (points collinear: the rotation about that line is undetermined).
 */
int pose_kabsch(const float (*model)[3], const float (*observed)[3], const float *w, size_t n,
                float r[3][3], float t[3]);

/* Angle of the rotation a^T * b in radians, in [0, pi]. */
float pose_rotation_angle(const float a[3][3], const float b[3][3]);

/*
 * Image of a circle's centre: a disc of radius radius_mm centred at centre (camera
 * frame, z > 0) with unit normal `normal` projects to an ellipse whose centre is
 * not the projection of the disc centre. Writes the ellipse centre in normalised
 * image coordinates (x/z, y/z). From the dual conic: c ~ C_z*C - r^2*(z - n_z*n).
 * Returns POSE_ERR_DEGENERATE if the disc is not in front of the camera.
 */
int pose_circle_image_centre(const float centre[3], const float normal[3], float radius_mm,
                             float out_xy[2]);

#ifdef __cplusplus
}
#endif

#endif /* POSE_POSE_LINALG_H */
