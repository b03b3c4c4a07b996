/*
 * Cramér-Rao bound for the attitude of the linear model of docs/explanation/architecture.md
 * (Eq. 5 of the first paper): θ = [x̄, tan α, tan β], one reading of sensor k
 * is h_kᵀθ + noise with variance σ_k², rows
 *   A: [1, −a, 0]   B: [1, 0, a]   C: [1, a, 0]   D: [1, 0, −a].
 * Fisher information of independent readings J = Σ h_k h_kᵀ / σ_k²; any
 * unbiased estimator of tan α has variance ≥ (J⁻¹)₂₂. Converted to degrees at
 * the true angle with dα/d(tan α) = 1/(1 + tan²α) (delta method). With equal σ
 * and n readings per sensor this is σ/(a·sqrt(2n)) in tan α: the bound that
 * α5 = atan((x_C − x_A)/2a) averaged over the window already attains.
 */
#ifndef SCENE_CRB_H
#define SCENE_CRB_H

#include <stddef.h>
#include <stdint.h>

#include "scene/row.h"

struct scene_crb {
    double sd_mean_mm;   /* bound on the standard deviation of x̄ */
    double sd_tan_alpha; /* ... of tan α */
    double sd_tan_beta;  /* ... of tan β */
    double sd_alpha_deg; /* ... of α in degrees at the true α */
    double sd_beta_deg;  /* ... of β in degrees at the true β */
};

/*
 * Bound for a window with n_valid[k] valid readings of sensor k, each with
 * standard deviation sigma_mm[k] > 0, at the true angles. Returns 0, or -1 if
 * α or β is unobservable (fewer than three sensors with readings) or an
 * argument is not positive and finite.
 */
int scene_crb(double arm_mm, const double sigma_mm[SCENE_SENSORS],
              const uint32_t n_valid[SCENE_SENSORS], double alpha_deg, double beta_deg,
              struct scene_crb *out);

/*
 * Bound when each sensor's noise over the window is white (sigma_mm[k]) plus a
 * constant offset of standard deviation offset_sd_mm[k] (slow drift that a
 * window cannot tell from the attitude): the window mean of sensor k is then
 * sufficient, with variance sigma²/n + offset_sd², so J = Σ h hᵀ/(σ²/n + σ_o²).
 * offset_sd_mm all 0 gives scene_crb(). Returns 0 or -1 like scene_crb().
 */
int scene_crb_with_offset(double arm_mm, const double sigma_mm[SCENE_SENSORS],
                          const double offset_sd_mm[SCENE_SENSORS],
                          const uint32_t n_valid[SCENE_SENSORS], double alpha_deg, double beta_deg,
                          struct scene_crb *out);

/*
 * Bound for the window rows[0..n): only valid readings (present, status 0)
 * count, each weighted by its own sigma_mm[i][k]; the angles converted at the
 * mean ground truth of the rows (which must all have it). Returns 0 or -1.
 */
int scene_crb_rows(double arm_mm, const struct scene_row *rows,
                   const double (*sigma_mm)[SCENE_SENSORS], size_t n, struct scene_crb *out);

#endif /* SCENE_CRB_H */
