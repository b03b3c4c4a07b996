/*
 * The five alpha and five beta estimates of one four-sensor sample (Eq. 1 of
 * the first paper, ../shared/seeds/000_*.txt) and the flatness residual.
 *
 * Geometry (docs/explanation/architecture.md): x_A = x̄ − a·tan α, x_C = x̄ + a·tan α,
 * x_B = x̄ + a·tan β, x_D = x̄ − a·tan β.
 *
 *   α1 = atan((x_B − x_A)/a)   α2 = atan((x_D − x_A)/a)
 *   α3 = atan((x_C − x_B)/a)   α4 = atan((x_C − x_D)/a)   α5 = atan((x_C − x_A)/2a)
 *
 * β by the symmetry that maps the α problem onto the β one (a 90° turn of the
 * sensor plate taking A→D, B→A, C→B, D→C: B/D become the sensing pair, A/C the
 * references):
 *
 *   β1 = atan((x_A − x_D)/a)   β2 = atan((x_C − x_D)/a)
 *   β3 = atan((x_B − x_A)/a)   β4 = atan((x_B − x_C)/a)   β5 = atan((x_B − x_D)/2a)
 *
 * So β3 = α1, β2 = α4, β1 = −α2, β4 = −α3: one sample needs six arctangents.
 *
 * Where the paper is silent: α1..α4 are exact only for β = 0. Their slopes are
 * tan α ± tan β (α1, α4: +; α2, α3: −), and likewise β1..β4 carry ∓tan α, so a
 * rotation about the other axis biases them; only α5 and β5 are free of it.
 * The paper tested β = 0 only. The residual x_A + x_C − x_B − x_D is exactly 0
 * for a flat plate at any attitude: a free parity check.
 */
#ifndef ESTIMATOR_ANGLES_H
#define ESTIMATOR_ANGLES_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/fixmath.h"

#define ANGLES_SENSORS  4u /* A, B, C, D */
#define ANGLES_PER_AXIS 5u /* α1..α5 (and β1..β5) */

/* Sensor indices and their bits in a sensor mask. */
enum angles_sensor { ANGLES_A = 0, ANGLES_B = 1, ANGLES_C = 2, ANGLES_D = 3 };
#define ANGLES_BIT(sensor) ((uint8_t)(1u << (unsigned)(sensor)))
#define ANGLES_ALL_SENSORS ((uint8_t)0x0Fu)

/* Arm length a accepted by the estimator, micrometres (1 mm .. 1 m). */
#define ANGLES_ARM_MIN_UM 1000
#define ANGLES_ARM_MAX_UM 1000000

/* Fine units of the corrected readings: 2^-10 mm, under a micrometre, so a
 * calibrated reading keeps its fraction of a millimetre through the angles and the sums.
 * Whole millimetres are exactly x · ANGLES_FINE_ONE, and every angle of them is the one
 * the millimetre functions give. Readings up to 65535 mm after a correction of up to
 * ±10 % and ±100 mm stay below 2^27 fine units. */
#define ANGLES_FINE_SHIFT 10u
#define ANGLES_FINE_ONE   1024

/* Sensors each α_i (β_i) uses, as sensor masks, index 0..4 = estimate 1..5. */
extern const uint8_t angles_alpha_sensors[ANGLES_PER_AXIS];
extern const uint8_t angles_beta_sensors[ANGLES_PER_AXIS];

struct angles_sample {
    fix_udeg_t alpha_udeg[ANGLES_PER_AXIS]; /* α1..α5; 0 where not valid */
    fix_udeg_t beta_udeg[ANGLES_PER_AXIS];  /* β1..β5; 0 where not valid */
    uint8_t alpha_valid;                    /* bit i: α_(i+1) computed from valid sensors */
    uint8_t beta_valid;
    bool flatness_valid; /* all four sensors valid */
    int32_t flatness_mm; /* x_A + x_C − x_B − x_D, 0 unless flatness_valid */
};

/* Bit i set when every sensor α_(i+1) (β_(i+1)) needs is in sensor_mask. */
uint8_t angles_alpha_mask(uint8_t sensor_mask);
uint8_t angles_beta_mask(uint8_t sensor_mask);

/* True if arm_um is inside [ANGLES_ARM_MIN_UM, ANGLES_ARM_MAX_UM]. */
bool angles_arm_valid(int32_t arm_um);

/* The arm prepared for the per-sample angles: its reciprocal, so that each angle of
 * Eq. 1 is a multiplication and a table lookup (fix_atan_unit_q31_udeg) instead of a
 * division and a CORDIC. */
struct angles_arm {
    int32_t arm_um;
    uint32_t inv;        /* round(2^(31 + shift) · 1000 / arm_um), in [2^31, 2^32) */
    uint32_t shift;      /* 1..10: |d| · inv / 2^shift is the slope |d| / a in Q31 */
    uint32_t fine_shift; /* shift + ANGLES_FINE_SHIFT: the same for d in fine units */
};

/* Prepares arm_um (which must satisfy angles_arm_valid()) for angles_compute_prepared(). */
void angles_arm_prepare(struct angles_arm *arm, int32_t arm_um);

/*
 * The ten angle estimates and the residual of one sample: range_mm[A..D] as the
 * sensors report them (any uint16, 0 and 65535 included), sensor_mask the
 * sensors whose reading is valid. arm_um must satisfy angles_arm_valid().
 */
void angles_compute(const uint16_t range_mm[ANGLES_SENSORS], uint8_t sensor_mask, int32_t arm_um,
                    struct angles_sample *out);

/* angles_compute() with a prepared arm: identical results, no division. */
void angles_compute_prepared(const uint16_t range_mm[ANGLES_SENSORS], uint8_t sensor_mask,
                             const struct angles_arm *arm, struct angles_sample *out);

/* angles_compute_prepared() of readings in fine units (|x| < 2^27); flatness_mm is the
 * residual rounded down to whole mm. */
void angles_compute_prepared_fine(const int32_t x[ANGLES_SENSORS], uint8_t sensor_mask,
                                  const struct angles_arm *arm, struct angles_sample *out);

/* angles_compute_all() of readings in fine units (|x| < 2^27). */
void angles_compute_all_fine(const int32_t x[ANGLES_SENSORS], const struct angles_arm *arm,
                             fix_udeg_t alpha_udeg[ANGLES_PER_AXIS], fix_udeg_t *beta5_udeg);

/* α1..α5 and β5 of a sample whose four readings are all valid (β1..β4 are ±α:
 * β1 = −α2, β2 = α4, β3 = α1, β4 = −α3), as angles_compute_prepared() gives them. */
void angles_compute_all(const uint16_t range_mm[ANGLES_SENSORS], const struct angles_arm *arm,
                        fix_udeg_t alpha_udeg[ANGLES_PER_AXIS], fix_udeg_t *beta5_udeg);

/* atan((x_hi − x_lo)/(span·a)) in udeg with a prepared arm, span 1 or 2: the one
 * primitive of Eq. 1; equal to angles_pair_udeg() up to the atan's rounding. */
fix_udeg_t angles_pair_prepared_udeg(uint16_t x_hi_mm, uint16_t x_lo_mm,
                                     const struct angles_arm *arm, unsigned span);

/* atan((x_hi − x_lo)/(span·a)) in udeg for integer mm readings: the one primitive of
 * Eq. 1 (span 1 for α1..α4, 2 for α5). */
fix_udeg_t angles_pair_udeg(uint16_t x_hi_mm, uint16_t x_lo_mm, int32_t arm_um, unsigned span);

#endif /* ESTIMATOR_ANGLES_H */
