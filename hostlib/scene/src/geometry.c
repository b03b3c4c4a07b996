/* Plate geometry, docs/explanation/architecture.md / Eq. 5 of the first paper. */
#include "scene/geometry.h"

#include <math.h>

void scene_ideal_distances(double arm_mm, double mean_mm, double alpha_deg, double beta_deg,
                           double out_mm[SCENE_SENSORS]) {
    const double ta = tan(scene_deg_to_rad(alpha_deg));
    const double tb = tan(scene_deg_to_rad(beta_deg));
    out_mm[SCENE_A] = mean_mm - arm_mm * ta;
    out_mm[SCENE_B] = mean_mm + arm_mm * tb;
    out_mm[SCENE_C] = mean_mm + arm_mm * ta;
    out_mm[SCENE_D] = mean_mm - arm_mm * tb;
}

void scene_attitude_from_distances(double arm_mm, const double d_mm[SCENE_SENSORS], double *mean_mm,
                                   double *alpha_deg, double *beta_deg) {
    /* HᵀH is diagonal (4, 2a², 2a²) for the rows of Eq. 5, so least squares
     * separates into these three averages. */
    *mean_mm = 0.25 * (d_mm[SCENE_A] + d_mm[SCENE_B] + d_mm[SCENE_C] + d_mm[SCENE_D]);
    *alpha_deg = scene_rad_to_deg(atan((d_mm[SCENE_C] - d_mm[SCENE_A]) / (2.0 * arm_mm)));
    *beta_deg = scene_rad_to_deg(atan((d_mm[SCENE_B] - d_mm[SCENE_D]) / (2.0 * arm_mm)));
}
