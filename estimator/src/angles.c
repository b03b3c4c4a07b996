/* Eq. 1 of the first paper and its β mirror: see estimator/angles.h. */
#include "estimator/angles.h"

#define A_ ANGLES_BIT(ANGLES_A)
#define B_ ANGLES_BIT(ANGLES_B)
#define C_ ANGLES_BIT(ANGLES_C)
#define D_ ANGLES_BIT(ANGLES_D)

const uint8_t angles_alpha_sensors[ANGLES_PER_AXIS] = {
    A_ | B_, /* α1 = atan((x_B − x_A)/a) */
    A_ | D_, /* α2 = atan((x_D − x_A)/a) */
    B_ | C_, /* α3 = atan((x_C − x_B)/a) */
    C_ | D_, /* α4 = atan((x_C − x_D)/a) */
    A_ | C_, /* α5 = atan((x_C − x_A)/2a) */
};

const uint8_t angles_beta_sensors[ANGLES_PER_AXIS] = {
    A_ | D_, /* β1 = atan((x_A − x_D)/a) */
    C_ | D_, /* β2 = atan((x_C − x_D)/a) */
    A_ | B_, /* β3 = atan((x_B − x_A)/a) */
    B_ | C_, /* β4 = atan((x_B − x_C)/a) */
    B_ | D_, /* β5 = atan((x_B − x_D)/2a) */
};

static uint8_t mask_of(const uint8_t needs[ANGLES_PER_AXIS], uint8_t sensor_mask) {
    uint8_t m = 0;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if ((needs[i] & sensor_mask) == needs[i]) {
            m = (uint8_t)(m | (1u << i));
        }
    }
    return m;
}

uint8_t angles_alpha_mask(uint8_t sensor_mask) {
    return mask_of(angles_alpha_sensors, sensor_mask);
}

uint8_t angles_beta_mask(uint8_t sensor_mask) {
    return mask_of(angles_beta_sensors, sensor_mask);
}

bool angles_arm_valid(int32_t arm_um) {
    return arm_um >= ANGLES_ARM_MIN_UM && arm_um <= ANGLES_ARM_MAX_UM;
}

fix_udeg_t angles_pair_udeg(uint16_t x_hi_mm, uint16_t x_lo_mm, int32_t arm_um, unsigned span) {
    /* Both operands in micrometres: the difference is exact, the ratio is what
     * atan2 resolves (|difference| <= 6.6e7 um, arm <= 2e6 um). */
    const int64_t diff_um = ((int64_t)x_hi_mm - (int64_t)x_lo_mm) * 1000;
    return fix_atan2_udeg(diff_um, (int64_t)arm_um * (int64_t)span);
}

void angles_compute(const uint16_t range_mm[ANGLES_SENSORS], uint8_t sensor_mask, int32_t arm_um,
                    struct angles_sample *out) {
    const uint16_t xa = range_mm[ANGLES_A];
    const uint16_t xb = range_mm[ANGLES_B];
    const uint16_t xc = range_mm[ANGLES_C];
    const uint16_t xd = range_mm[ANGLES_D];
    const uint8_t am = angles_alpha_mask(sensor_mask);
    const uint8_t bm = angles_beta_mask(sensor_mask);

    /* The six distinct arctangents, each only when its two sensors are valid. */
    const bool ab = (sensor_mask & (A_ | B_)) == (A_ | B_);
    const bool ad = (sensor_mask & (A_ | D_)) == (A_ | D_);
    const bool bc = (sensor_mask & (B_ | C_)) == (B_ | C_);
    const bool cd = (sensor_mask & (C_ | D_)) == (C_ | D_);
    const bool ac = (sensor_mask & (A_ | C_)) == (A_ | C_);
    const bool bd = (sensor_mask & (B_ | D_)) == (B_ | D_);
    const fix_udeg_t d_ba = ab ? angles_pair_udeg(xb, xa, arm_um, 1u) : 0;
    const fix_udeg_t d_da = ad ? angles_pair_udeg(xd, xa, arm_um, 1u) : 0;
    const fix_udeg_t d_cb = bc ? angles_pair_udeg(xc, xb, arm_um, 1u) : 0;
    const fix_udeg_t d_cd = cd ? angles_pair_udeg(xc, xd, arm_um, 1u) : 0;
    const fix_udeg_t h_ca = ac ? angles_pair_udeg(xc, xa, arm_um, 2u) : 0;
    const fix_udeg_t h_bd = bd ? angles_pair_udeg(xb, xd, arm_um, 2u) : 0;

    out->alpha_udeg[0] = d_ba;
    out->alpha_udeg[1] = d_da;
    out->alpha_udeg[2] = d_cb;
    out->alpha_udeg[3] = d_cd;
    out->alpha_udeg[4] = h_ca;
    /* atan2 is exactly odd in y, so the mirrored β are exact negations. */
    out->beta_udeg[0] = -d_da;
    out->beta_udeg[1] = d_cd;
    out->beta_udeg[2] = d_ba;
    out->beta_udeg[3] = -d_cb;
    out->beta_udeg[4] = h_bd;
    out->alpha_valid = am;
    out->beta_valid = bm;
    out->flatness_valid = (sensor_mask & ANGLES_ALL_SENSORS) == ANGLES_ALL_SENSORS;
    out->flatness_mm =
        out->flatness_valid ? (int32_t)xa + (int32_t)xc - (int32_t)xb - (int32_t)xd : 0;
}
