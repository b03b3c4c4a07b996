/* The re-zero at the latched position: offsets refitted from N samples, gains kept
 * (firmware/rezero.h). */
#include "firmware/rezero.h"

#include <string.h>

#include "estimator/fixmath.h"

bool tof_rezero_start(struct tof_rezero *z, uint16_t samples) {
    if (samples < TOF_REZERO_MIN || samples > TOF_REZERO_MAX) {
        return false;
    }
    memset(z, 0, sizeof *z);
    z->wanted = samples;
    return true;
}

bool tof_rezero_add(struct tof_rezero *z, const struct tof_sample *sample) {
    if (z->wanted == 0u || z->seen >= z->wanted) {
        return false;
    }
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        if ((sample->present_mask & (1u << i)) != 0u && sample->status[i] == 0u) {
            const uint64_t r = sample->range_mm[i];
            ++z->n[i];
            z->sum[i] += r;
            z->sum2[i] += r * r;
        }
    }
    if (sample->temp_known) {
        z->temp_sum += sample->temp_cdeg; /* |.| <= 5000 · 32767: within 2^31 */
        ++z->temp_n;
    }
    ++z->seen;
    return z->seen == z->wanted;
}

/* ⌊√v⌋, bit by bit: 32 bounded steps. */
static uint32_t isqrt64(uint64_t v) {
    uint64_t root = 0;
    for (int bit = 31; bit >= 0; --bit) {
        const uint64_t trial = root | (1ull << (unsigned)bit);
        if (trial * trial <= v) {
            root = trial;
        }
    }
    return (uint32_t)root;
}

/* Sensor i's mean reading in µm and the variance of that mean in µm². */
static void mean_and_var(const struct tof_rezero *z, unsigned i, int64_t *mean_um,
                         uint64_t *var_um2) {
    const uint64_t n = z->n[i];
    *mean_um = (int64_t)((z->sum[i] * 1000u + n / 2u) / n);
    /* (Σr² − (Σr)²/n) / (n − 1) in mm², times 10^6 for µm², over n for the mean */
    const uint64_t ss = z->sum2[i] * n - z->sum[i] * z->sum[i]; /* n·Σ(r − m)² ≥ 0 */
    uint64_t var = ss * 1000000u / (n * (n - 1u)) / n;
    const uint64_t floor = 1000000u / 12u / n; /* (1 mm)²/12 per reading */
    *var_um2 = var > floor ? var : floor;
}

/* `cal` as in force at the samples' mean temperature (rezero.h) into *at, and each offset's
 * variance there from the coefficient's error. false: thermal without a temperature. */
static bool in_force_now(const struct tof_rezero *z, const struct calibration_head *cal,
                         struct calibration_head *at, uint64_t var_coeff[CALIBRATION_SENSORS]) {
    *at = *cal;
    memset(var_coeff, 0, CALIBRATION_SENSORS * sizeof var_coeff[0]);
    if (!cal->thermal) {
        return true;
    }
    if (z->temp_n == 0u) {
        return false;
    }
    at->cal_temp_cdeg = (int16_t)fix_div_round_s64(z->temp_sum, z->temp_n);
    const int64_t dt = (int64_t)at->cal_temp_cdeg - cal->cal_temp_cdeg;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        /* nm/°C · 0.01 °C / 10^5 = µm (|.| <= 10^6 · 3·10^4: within 2^45) */
        const int64_t shift = fix_div_round_s64((int64_t)cal->temp_coeff_nm_per_c[i] * dt, 100000);
        const int64_t sd = fix_div_round_s64((int64_t)cal->temp_coeff_sd_nm_per_c[i] * dt, 100000);
        at->offset_um[i] = (int32_t)(cal->offset_um[i] + shift); /* the fit checks its bound */
        var_coeff[i] = (uint64_t)(sd * sd);
    }
    return true;
}

bool tof_rezero_fit(const struct tof_rezero *z, const struct calibration_head *in_cal,
                    struct calibration_head *out) {
    struct calibration_head now;
    uint64_t var_coeff[CALIBRATION_SENSORS];
    if (!in_cal->calibrated || z->wanted == 0u || z->seen < z->wanted ||
        !in_force_now(z, in_cal, &now, var_coeff)) {
        return false;
    }
    const struct calibration_head *cal = &now;
    int64_t m[CALIBRATION_SENSORS];
    uint64_t var_m[CALIBRATION_SENSORS];
    int64_t num = 0, g_sum = 0;
    uint64_t var_m_sum = 0, var_o_sum = 0;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        if (z->n[i] < 2u || 2u * z->n[i] < z->seen) {
            return false;
        }
        mean_and_var(z, i, &m[i], &var_m[i]);
        num += m[i] - cal->offset_um[i];
        g_sum += 1000000 + cal->gain_ppm[i];
        var_m_sum += var_m[i];
        var_o_sum += (uint64_t)cal->offset_sd_um[i] * cal->offset_sd_um[i] + var_coeff[i];
    }
    /* x̂ in µm, rounded to nearest (num ≥ 0 at any distance a VL53 reports) */
    const int64_t x_um = fix_div_trunc_s64(num * 1000000 + g_sum / 2, g_sum);
    struct calibration_head next = *cal;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        const int64_t gx = x_um + fix_div_trunc_s64(x_um * cal->gain_ppm[i], 1000000); /* g_i·x̂ */
        const int64_t o = m[i] - gx;
        if (o < -CALIBRATION_OFFSET_MAX_UM || o > CALIBRATION_OFFSET_MAX_UM) {
            return false;
        }
        next.offset_um[i] = (int32_t)o;
        next.offset_sd_um[i] = isqrt64(var_m[i] / 2u + var_m_sum / 16u + var_o_sum / 16u);
    }
    *out = next;
    return true;
}
