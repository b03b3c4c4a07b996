/*
 * Plate geometry of docs/explanation/architecture.md (the measurement model of Eq. 5 in the first
 * paper): four sensors at distance a (arm_mm) from the plate centre.
 *   x_A = x̄ − a·tan α   x_C = x̄ + a·tan α   x_B = x̄ + a·tan β   x_D = x̄ − a·tan β
 */
#ifndef SCENE_GEOMETRY_H
#define SCENE_GEOMETRY_H

#include "scene/row.h"

#define SCENE_PI 3.14159265358979323846

static inline double scene_deg_to_rad(double deg) {
    return deg * (SCENE_PI / 180.0);
}
static inline double scene_rad_to_deg(double rad) {
    return rad * (180.0 / SCENE_PI);
}

/* Ideal (noise-free, unquantised) distances in mm for a plate at mean distance
 * mean_mm tilted by alpha_deg about z and beta_deg about y; out_mm[A..D]. */
void scene_ideal_distances(double arm_mm, double mean_mm, double alpha_deg, double beta_deg,
                           double out_mm[SCENE_SENSORS]);

/* Inverse of scene_ideal_distances for a flat plate (least squares over the four
 * rows of Eq. 5): x̄ = mean of the four, tan α = (x_C − x_A)/2a, tan β = (x_B − x_D)/2a. */
void scene_attitude_from_distances(double arm_mm, const double d_mm[SCENE_SENSORS], double *mean_mm,
                                   double *alpha_deg, double *beta_deg);

#endif /* SCENE_GEOMETRY_H */
