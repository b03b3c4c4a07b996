/* Eq. 1 of the first paper and its β mirror: see estimator/angles.h. */
#include "estimator/angles.h"

#include "fixmath_internal.h"

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

void angles_arm_prepare(struct angles_arm *arm, int32_t arm_um) {
    arm->arm_um = arm_um;
    /* shift = ceil(log2(a in mm)), at least 1: 2^(31 + shift) · 1000 / a in [2^31, 2^32]
     * (2^32 only for a = 1 mm, stored as 2^32 − 1: 2^-32 relative) */
    uint32_t shift = 1u;
    while (shift < 10u && ((int64_t)1000 << shift) < (int64_t)arm_um) {
        ++shift;
    }
    const int64_t inv = fix_div_round_s64((int64_t)1000 << (31u + shift), arm_um); /* < 2^52 */
    arm->inv = inv > (int64_t)UINT32_MAX ? UINT32_MAX : (uint32_t)inv;
    arm->shift = shift;
    arm->fine_shift = shift + ANGLES_FINE_SHIFT;
}

/* atan(d / (span·a)) beyond 45°: the CORDIC on the exact operands, the difference in µm
 * (exact for whole millimetres: 1024 fine units are 1000 µm). */
static fix_udeg_t pair_far(int64_t diff_fine, int32_t arm_um, unsigned span) {
    const int64_t diff_um = fix_div_round_s64(diff_fine * 125, 128);
    return fix_atan2_udeg(diff_um, (int64_t)arm_um * (int64_t)span);
}

/* atan(d / (span·a)) of two readings in fine units (2^-ANGLES_FINE_SHIFT mm): |d| / (span·a)
 * in Q31 from the reciprocal with one 32x32 -> 64 product (|d| < 2^27), the table within
 * 45°, the CORDIC beyond. Whole millimetres (d a multiple of 2^10) give exactly what the
 * millimetre path gave: the product is 2^10 times larger and shifted 10 bits further. */
FIX_INLINE fix_udeg_t pair_angle(int32_t x_hi, int32_t x_lo, const struct angles_arm *arm,
                                 unsigned span) {
    const bool neg = x_hi < x_lo;
    const uint32_t m = neg ? (uint32_t)x_lo - (uint32_t)x_hi : (uint32_t)x_hi - (uint32_t)x_lo;
    const unsigned sh = arm->fine_shift + (span - 1u); /* 11..21 */
    const uint64_t p = (uint64_t)m * arm->inv;
    const uint32_t lo = (uint32_t)p;
    const uint32_t hi = (uint32_t)(p >> 32);
    if ((hi >> (sh - 1u)) != 0u) { /* slope >= 1 */
        return pair_far((int64_t)x_hi - (int64_t)x_lo, arm->arm_um, span);
    }
    const fix_udeg_t a = fix_atan_q31_inline((lo >> sh) | (hi << (32u - sh)));
    return neg ? -a : a;
}

static fix_udeg_t pair1(int32_t x_hi, int32_t x_lo, const struct angles_arm *arm) {
    return pair_angle(x_hi, x_lo, arm, 1u);
}

static fix_udeg_t pair2(int32_t x_hi, int32_t x_lo, const struct angles_arm *arm) {
    return pair_angle(x_hi, x_lo, arm, 2u);
}

/* Whole millimetres as fine units. */
static int32_t fine(uint16_t x_mm) {
    return (int32_t)x_mm * ANGLES_FINE_ONE;
}

fix_udeg_t angles_pair_prepared_udeg(uint16_t x_hi_mm, uint16_t x_lo_mm,
                                     const struct angles_arm *arm, unsigned span) {
    return span == 2u ? pair2(fine(x_hi_mm), fine(x_lo_mm), arm)
                      : pair1(fine(x_hi_mm), fine(x_lo_mm), arm);
}

void angles_compute_all_fine(const int32_t x[ANGLES_SENSORS], const struct angles_arm *arm,
                             fix_udeg_t alpha_udeg[ANGLES_PER_AXIS], fix_udeg_t *beta5_udeg) {
    const int32_t xa = x[ANGLES_A];
    const int32_t xb = x[ANGLES_B];
    const int32_t xc = x[ANGLES_C];
    const int32_t xd = x[ANGLES_D];
    alpha_udeg[0] = pair1(xb, xa, arm);
    alpha_udeg[1] = pair1(xd, xa, arm);
    alpha_udeg[2] = pair1(xc, xb, arm);
    alpha_udeg[3] = pair1(xc, xd, arm);
    alpha_udeg[4] = pair2(xc, xa, arm);
    *beta5_udeg = pair2(xb, xd, arm);
}

void angles_compute_all(const uint16_t range_mm[ANGLES_SENSORS], const struct angles_arm *arm,
                        fix_udeg_t alpha_udeg[ANGLES_PER_AXIS], fix_udeg_t *beta5_udeg) {
    const int32_t x[ANGLES_SENSORS] = {fine(range_mm[0]), fine(range_mm[1]), fine(range_mm[2]),
                                       fine(range_mm[3])};
    angles_compute_all_fine(x, arm, alpha_udeg, beta5_udeg);
}

void angles_compute(const uint16_t range_mm[ANGLES_SENSORS], uint8_t sensor_mask, int32_t arm_um,
                    struct angles_sample *out) {
    struct angles_arm arm;
    angles_arm_prepare(&arm, arm_um);
    angles_compute_prepared(range_mm, sensor_mask, &arm, out);
}

void angles_compute_prepared_fine(const int32_t x[ANGLES_SENSORS], uint8_t sensor_mask,
                                  const struct angles_arm *arm, struct angles_sample *out) {
    const int32_t xa = x[ANGLES_A];
    const int32_t xb = x[ANGLES_B];
    const int32_t xc = x[ANGLES_C];
    const int32_t xd = x[ANGLES_D];
    const uint8_t am = angles_alpha_mask(sensor_mask);
    const uint8_t bm = angles_beta_mask(sensor_mask);

    /* The six distinct arctangents, each only when its two sensors are valid. */
    const bool ab = (sensor_mask & (A_ | B_)) == (A_ | B_);
    const bool ad = (sensor_mask & (A_ | D_)) == (A_ | D_);
    const bool bc = (sensor_mask & (B_ | C_)) == (B_ | C_);
    const bool cd = (sensor_mask & (C_ | D_)) == (C_ | D_);
    const bool ac = (sensor_mask & (A_ | C_)) == (A_ | C_);
    const bool bd = (sensor_mask & (B_ | D_)) == (B_ | D_);
    const fix_udeg_t d_ba = ab ? pair1(xb, xa, arm) : 0;
    const fix_udeg_t d_da = ad ? pair1(xd, xa, arm) : 0;
    const fix_udeg_t d_cb = bc ? pair1(xc, xb, arm) : 0;
    const fix_udeg_t d_cd = cd ? pair1(xc, xd, arm) : 0;
    const fix_udeg_t h_ca = ac ? pair2(xc, xa, arm) : 0;
    const fix_udeg_t h_bd = bd ? pair2(xb, xd, arm) : 0;

    out->alpha_udeg[0] = d_ba;
    out->alpha_udeg[1] = d_da;
    out->alpha_udeg[2] = d_cb;
    out->alpha_udeg[3] = d_cd;
    out->alpha_udeg[4] = h_ca;
    /* every angle is exactly odd in the difference, so the mirrored β are exact negations */
    out->beta_udeg[0] = -d_da;
    out->beta_udeg[1] = d_cd;
    out->beta_udeg[2] = d_ba;
    out->beta_udeg[3] = -d_cb;
    out->beta_udeg[4] = h_bd;
    out->alpha_valid = am;
    out->beta_valid = bm;
    out->flatness_valid = (sensor_mask & ANGLES_ALL_SENSORS) == ANGLES_ALL_SENSORS;
    /* whole mm (exact for whole-mm readings, rounded down otherwise) */
    out->flatness_mm = out->flatness_valid ? (xa + xc - xb - xd) >> ANGLES_FINE_SHIFT : 0;
}

void angles_compute_prepared(const uint16_t range_mm[ANGLES_SENSORS], uint8_t sensor_mask,
                             const struct angles_arm *arm, struct angles_sample *out) {
    const int32_t x[ANGLES_SENSORS] = {fine(range_mm[0]), fine(range_mm[1]), fine(range_mm[2]),
                                       fine(range_mm[3])};
    angles_compute_prepared_fine(x, sensor_mask, arm, out);
}
