/* Window sums, gate and statistics: see estimator/window_stats.h. */
#include "estimator/window_stats.h"

#include <string.h>

#include "fixmath_internal.h"
#include "window_internal.h"

_Static_assert(WINDOW_MAX_SAMPLES >= 255u, "windows of at least 255 rows are required");
_Static_assert(WINDOW_MAX_SAMPLES <= 1024u, "exact 64-bit sums of angle products need N <= 1024");
_Static_assert(sizeof(struct window_row) == 10u, "a window row is 10 bytes (the RAM budget)");

unsigned window_pair_index(unsigned i, unsigned j) {
    const unsigned lo = i < j ? i : j;
    const unsigned hi = i < j ? j : i;
    /* rows of the upper triangle hold 5, 4, 3, 2, 1 entries: row lo starts at lo(11 − lo)/2 */
    return (lo * (2u * ANGLES_PER_AXIS + 1u - lo)) / 2u + (hi - lo);
}

int window_init(struct window_state *w, const struct window_config *cfg) {
    if (!angles_arm_valid(cfg->arm_um)) {
        return WINDOW_ERR_ARM;
    }
    if (cfg->length < WINDOW_MIN_SAMPLES || cfg->length > WINDOW_MAX_SAMPLES) {
        return WINDOW_ERR_LENGTH;
    }
    w->cfg = *cfg;
    angles_arm_prepare(&w->arm, cfg->arm_um);
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        /* µm as fine units: · 1024/1000; 1/gain − 1 = −ppm/(10^6 + ppm), in Q32 (|.| < 2^31
         * for gains within ±10 %); all exactly 0 for an identity calibration */
        w->cal_offset_fine[k] = (int32_t)fix_div_round_s64((int64_t)cfg->offset_um[k] * 128, 125);
        w->cal_base_offset_fine[k] = w->cal_offset_fine[k];
        w->cal_inv_gain_q32[k] = (int32_t)fix_muldiv_s64(-(int64_t)cfg->gain_ppm[k], FIX_Q32_ONE,
                                                         1000000 + (int64_t)cfg->gain_ppm[k], NULL);
        const int64_t r = w->cal_inv_gain_q32[k]; /* (1 + r)² − 1 = 2r + r² */
        w->cal_inv_gain2_q32[k] = 2 * r + fix_mul_shr_s64(r, r, FIX_Q32_SHIFT, NULL);
        w->newest_fine[k] = 0;
        w->newest_mm[k] = 0;
        /* nothing left over yet: the first row rounds to nearest (window_internal.h) */
        w->newest_carry[k] = (uint32_t)ANGLES_FINE_ONE / 2u;
    }
    window_clear(w);
    return WINDOW_OK;
}

void window_clear(struct window_state *w) {
    w->oldest = 0;
    w->fill = 0;
    (void)memset(&w->sums, 0, sizeof w->sums);
}

/* A row count moved by sign (+1 adds a row, −1 removes one), in unsigned arithmetic. */
static uint16_t count_step(uint16_t count, int32_t sign) {
    return (uint16_t)(sign > 0 ? count + 1u : count - 1u);
}

/* A complete row (all four readings used): the six distinct angles, their sums and
 * the 20 distinct products. sign −1 removes the row: the first factor of every product
 * is negated, so exactly what was added is subtracted. */
static void contrib_complete(struct window_sums *s, const int32_t x[ANGLES_SENSORS],
                             const struct angles_arm *arm, int32_t sign) {
    fix_udeg_t al[ANGLES_PER_AXIS];
    fix_udeg_t b5;
    angles_compute_all_fine(x, arm, al, &b5);
    const int32_t a1 = al[0];
    const int32_t a2 = al[1];
    const int32_t a3 = al[2];
    const int32_t a4 = al[3];
    const int32_t a5 = al[4];
    /* the first factors, negated to remove the row */
    const int32_t s1 = sign * a1;
    const int32_t s2 = sign * a2;
    const int32_t s3 = sign * a3;
    const int32_t s4 = sign * a4;
    const int32_t s5 = sign * a5;
    const int32_t sb5 = sign * b5;
    int64_t *p = s->alpha_prod; /* packed i <= j: 11 12 13 14 15 22 23 24 25 33 34 35 44 45 55 */
    p[0] += (int64_t)s1 * a1;
    p[1] += (int64_t)s1 * a2;
    p[2] += (int64_t)s1 * a3;
    p[3] += (int64_t)s1 * a4;
    p[4] += (int64_t)s1 * a5;
    p[5] += (int64_t)s2 * a2;
    p[6] += (int64_t)s2 * a3;
    p[7] += (int64_t)s2 * a4;
    p[8] += (int64_t)s2 * a5;
    p[9] += (int64_t)s3 * a3;
    p[10] += (int64_t)s3 * a4;
    p[11] += (int64_t)s3 * a5;
    p[12] += (int64_t)s4 * a4;
    p[13] += (int64_t)s4 * a5;
    p[14] += (int64_t)s5 * a5;
    int64_t *q = s->beta5_prod;
    q[0] += (int64_t)sb5 * a1;
    q[1] += (int64_t)sb5 * a2;
    q[2] += (int64_t)sb5 * a3;
    q[3] += (int64_t)sb5 * a4;
    q[4] += (int64_t)sb5 * b5;
    s->alpha_sum[0] += s1;
    s->alpha_sum[1] += s2;
    s->alpha_sum[2] += s3;
    s->alpha_sum[3] += s4;
    s->alpha_sum[4] += s5;
    s->beta5_sum += sb5;
    s->complete = count_step(s->complete, sign);
    const int32_t residual = x[ANGLES_A] + x[ANGLES_C] - x[ANGLES_B] - x[ANGLES_D];
    s->residual_sum_fine += (int64_t)sign * residual;
}

/* An incomplete row: the valid angles into the per-angle sums only. */
static void contrib_partial(struct window_sums *s, const int32_t x[ANGLES_SENSORS], uint8_t mask,
                            const struct angles_arm *arm, int32_t sign) {
    struct angles_sample a;
    angles_compute_prepared_fine(x, mask, arm, &a);
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if ((a.alpha_valid & (1u << i)) != 0u) {
            s->partial_alpha_sum[i] += (int64_t)sign * a.alpha_udeg[i];
            s->partial_alpha_count[i] = count_step(s->partial_alpha_count[i], sign);
        }
    }
    if ((a.beta_valid & 0x10u) != 0u) {
        s->partial_beta5_sum += (int64_t)sign * a.beta_udeg[4];
        s->partial_beta5_count = count_step(s->partial_beta5_count, sign);
    }
}

/* Adds (sign +1) or removes (sign −1) the readings of row selected by mask (x: the row's
 * corrected readings, window_correct). */
static void contrib(struct window_sums *s, const struct window_row *row,
                    const int32_t xf[ANGLES_SENSORS], uint8_t mask, const struct angles_arm *arm,
                    int32_t sign) {
    if (mask == 0u) {
        return;
    }
    /* per sensor Σx, Σx², n: modulo-2^32/2^64 arithmetic, so adding the negated value
     * removes exactly what was added */
    const uint32_t step = sign > 0 ? 1u : UINT32_MAX;
    const uint64_t step64 = sign > 0 ? 1u : UINT64_MAX;
    if (mask == ANGLES_ALL_SENSORS && sign > 0) { /* the common row, unrolled */
        const uint16_t *x = row->range_mm;
        s->sum_mm[0] += x[0];
        s->sum_mm[1] += x[1];
        s->sum_mm[2] += x[2];
        s->sum_mm[3] += x[3];
        s->sum_sq_mm2[0] += (uint64_t)((uint32_t)x[0] * x[0]);
        s->sum_sq_mm2[1] += (uint64_t)((uint32_t)x[1] * x[1]);
        s->sum_sq_mm2[2] += (uint64_t)((uint32_t)x[2] * x[2]);
        s->sum_sq_mm2[3] += (uint64_t)((uint32_t)x[3] * x[3]);
        s->count[0]++;
        s->count[1]++;
        s->count[2]++;
        s->count[3]++;
        contrib_complete(s, xf, arm, sign);
        return;
    }
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        if ((mask & (1u << k)) != 0u) {
            const uint32_t x = row->range_mm[k];
            s->sum_mm[k] += x * step;
            s->sum_sq_mm2[k] += ((uint64_t)x * x) * step64;
            s->count[k] = (uint16_t)(s->count[k] + step);
        }
    }
    if ((mask & ANGLES_ALL_SENSORS) == ANGLES_ALL_SENSORS) {
        contrib_complete(s, xf, arm, sign);
    } else {
        contrib_partial(s, xf, mask, arm, sign);
    }
}

struct window_row *window_push(struct window_state *w, const uint16_t range_mm[ANGLES_SENSORS],
                               uint8_t present_mask, uint8_t valid_mask) {
    if (w->fill >= w->cfg.length) {
        const struct window_row *old = &w->ring[w->oldest];
        int32_t xo[ANGLES_SENSORS];
        window_correct(w, old->range_mm, xo);
        contrib(&w->sums, old, xo, window_row_valid(old), &w->arm, -1);
        w->oldest = (uint16_t)((w->oldest + 1u) % w->cfg.length);
        w->fill--;
    }
    /* unsigned (not the promoted int's) remainder: the same value, and a Cortex-M0 image
     * links no signed division helper (~0.45 KB of flash) */
    const uint16_t slot = (uint16_t)(((uint32_t)w->oldest + w->fill) % w->cfg.length);
    struct window_row *row = &w->ring[slot];
    (void)memcpy(row->range_mm, range_mm, sizeof row->range_mm);
    const uint8_t present = (uint8_t)(present_mask & ANGLES_ALL_SENSORS);
    const uint8_t valid = (uint8_t)(valid_mask & present);
    row->masks = (uint8_t)(present | (uint8_t)(valid << 4));
    row->aux = 0;
    w->fill++;
    window_correct_newest(w, range_mm);
    contrib(&w->sums, row, w->newest_fine, valid, &w->arm, +1);
    return row;
}

void window_shift_offsets(struct window_state *w, const int32_t shift_fine[ANGLES_SENSORS]) {
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        w->cal_offset_fine[k] = w->cal_base_offset_fine[k] + shift_fine[k];
    }
    (void)memset(&w->sums, 0, sizeof w->sums);
    for (uint16_t i = 0; i < w->fill; ++i) { /* fill <= length <= WINDOW_MAX_SAMPLES */
        const struct window_row *row = &w->ring[((uint32_t)w->oldest + i) % w->cfg.length];
        int32_t x[ANGLES_SENSORS];
        window_correct(w, row->range_mm, x);
        contrib(&w->sums, row, x, window_row_valid(row), &w->arm, +1);
    }
}

uint16_t window_fill(const struct window_state *w) {
    return w->fill;
}

struct window_row *window_row_at(struct window_state *w, uint16_t age) {
    if (age >= w->fill) {
        return NULL;
    }
    return &w->ring[(w->oldest + w->fill - 1u - age) % w->cfg.length];
}

/* --- statistics from sums ---------------------------------------------------------- */

static fix_udeg_q16_t mean_q16(int64_t sum, uint16_t n) {
    return n == 0u ? 0 : fix_div_round_s64(sum * (int64_t)(1 << FIX_UDEG_Q_SHIFT), n);
}

/* One axis's sums in the layout of its statistics. */
struct axis_sums {
    int64_t sum[ANGLES_PER_AXIS]; /* all rows where the estimate is valid */
    uint16_t count[ANGLES_PER_AXIS];
    int64_t complete_sum[ANGLES_PER_AXIS];
    int64_t complete_prod[WINDOW_PAIRS];
};

static void alpha_sums(const struct window_sums *g, struct axis_sums *out) {
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        out->complete_sum[i] = g->alpha_sum[i];
        out->sum[i] = g->alpha_sum[i] + g->partial_alpha_sum[i];
        out->count[i] = (uint16_t)(g->complete + g->partial_alpha_count[i]);
    }
    (void)memcpy(out->complete_prod, g->alpha_prod, sizeof out->complete_prod);
}

/* β1..β4 as ±α (angles.h): β_(i+1) = beta_sign[i] · α_(beta_of[i]+1). */
static const uint8_t beta_of[4] = {1u, 3u, 0u, 2u};
static const int8_t beta_sign[4] = {-1, 1, 1, -1};

static void beta_sums(const struct window_sums *g, struct axis_sums *out) {
    for (unsigned i = 0; i < 4u; ++i) {
        const unsigned m = beta_of[i];
        out->complete_sum[i] = beta_sign[i] * g->alpha_sum[m];
        out->sum[i] = beta_sign[i] * (g->alpha_sum[m] + g->partial_alpha_sum[m]);
        out->count[i] = (uint16_t)(g->complete + g->partial_alpha_count[m]);
        for (unsigned j = i; j < 4u; ++j) {
            out->complete_prod[window_pair_index(i, j)] =
                (int64_t)(beta_sign[i] * beta_sign[j]) *
                g->alpha_prod[window_pair_index(m, beta_of[j])];
        }
        out->complete_prod[window_pair_index(i, 4u)] = beta_sign[i] * g->beta5_prod[m];
    }
    out->complete_sum[4] = g->beta5_sum;
    out->sum[4] = g->beta5_sum + g->partial_beta5_sum;
    out->count[4] = (uint16_t)(g->complete + g->partial_beta5_count);
    out->complete_prod[window_pair_index(4u, 4u)] = g->beta5_prod[4];
}

static void axis_stats(const struct axis_sums *s, uint16_t complete,
                       struct window_axis_stats *out) {
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        out->mean[i] = mean_q16(s->sum[i], s->count[i]);
        out->count[i] = s->count[i];
        out->complete_mean[i] = mean_q16(s->complete_sum[i], complete);
    }
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        for (unsigned j = i; j < ANGLES_PER_AXIS; ++j) {
            int64_t c = 0;
            if (complete >= 2u) {
                /* cov = (n Σα_iα_j − Σα_i Σα_j) / (n (n − 1)), exact numerator in 128 bits */
                const fix_s128 num =
                    fix_s128_sub(fix_s128_mul(complete, s->complete_prod[window_pair_index(i, j)]),
                                 fix_s128_mul(s->complete_sum[i], s->complete_sum[j]));
                c = fix_s128_div_s64(num, (int64_t)complete * ((int64_t)complete - 1), NULL);
            }
            out->cov[i][j] = c;
            out->cov[j][i] = c;
        }
    }
}

/* The α and β statistics (not inlined: its sums stay off the gate's stack). */
FIX_NOINLINE void both_axes(const struct window_sums *g, struct window_stats *out) {
    struct axis_sums axis;
    alpha_sums(g, &axis);
    axis_stats(&axis, g->complete, &out->alpha);
    beta_sums(g, &axis);
    axis_stats(&axis, g->complete, &out->beta);
}

void window_compute(struct window_state *w, struct window_stats *out) {
    (void)memset(out, 0, sizeof *out);
    out->rows = w->fill;
    struct window_sums *g = &w->gated;
    *g = w->sums;

    int32_t median_x2[ANGLES_SENSORS];
    int32_t half_x2[ANGLES_SENSORS];
    bool gate_on[ANGLES_SENSORS];
    window_gate_sensors(w, w->sums.count, median_x2, half_x2, gate_on);
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        out->sensor[k].median_x2_mm = median_x2[k];
        out->sensor[k].gate_x2_mm = half_x2[k];
    }

    uint16_t idx = w->oldest;
    for (uint16_t r = 0; r < w->fill; ++r) {
        const struct window_row *row = &w->ring[idx];
        idx = (uint16_t)(idx + 1u == w->cfg.length ? 0u : idx + 1u);
        uint8_t rejected = 0;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            const uint8_t bit = (uint8_t)(1u << k);
            struct window_sensor_stats *ss = &out->sensor[k];
            if ((window_row_present(row) & bit) == 0u) {
                ss->missing++;
            } else if ((window_row_valid(row) & bit) == 0u) {
                ss->flagged++;
            } else {
                int32_t dev = 2 * (int32_t)row->range_mm[k] - median_x2[k];
                dev = dev < 0 ? -dev : dev;
                if (gate_on[k] && dev > half_x2[k]) {
                    rejected = (uint8_t)(rejected | bit);
                    ss->rejected++;
                }
            }
        }
        if (rejected != 0u) {
            /* exact: remove the row as it was added, add back what survives */
            const uint8_t valid = window_row_valid(row);
            int32_t xr[ANGLES_SENSORS];
            window_correct(w, row->range_mm, xr);
            contrib(g, row, xr, valid, &w->arm, -1);
            contrib(g, row, xr, (uint8_t)(valid ^ (valid & rejected)), &w->arm, +1);
        }
    }

    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        struct window_sensor_stats *ss = &out->sensor[k];
        const uint16_t n = g->count[k];
        ss->used = n;
        if (n == 0u) {
            continue;
        }
        ss->mean_mm = fix_div_round_s64((int64_t)g->sum_mm[k] << FIX_Q32_SHIFT, n);
        if (n >= 2u) {
            /* var = (n Σx² − (Σx)²) / (n (n − 1)) in Q32, exact numerator */
            const fix_s128 num =
                fix_s128_sub(fix_s128_mul(n, (int64_t)g->sum_sq_mm2[k]),
                             fix_s128_mul((int64_t)g->sum_mm[k], (int64_t)g->sum_mm[k]));
            ss->var_mm2 = fix_s128_div_s64(fix_s128_shl(num, FIX_Q32_SHIFT),
                                           (int64_t)n * ((int64_t)n - 1), NULL);
        }
        correct_stats(w, k, ss);
    }
    out->complete = g->complete;
    both_axes(g, out);
    if (g->complete > 0u) {
        out->residual_valid = true;
        /* fine units as µm: · 1000/1024 = · 125/128 (exact for whole-mm readings) */
        out->residual_um =
            fix_sat_s32(fix_div_round_s64(g->residual_sum_fine * 125, 128 * (int64_t)g->complete));
    }
}
