/* Window sums, gate and statistics: see estimator/window_stats.h. */
#include "estimator/window_stats.h"

#include <string.h>

_Static_assert(WINDOW_MAX_SAMPLES >= 255u, "the issue asks for windows of at least 255 rows");
_Static_assert(WINDOW_MAX_SAMPLES <= 1024u, "exact 64-bit sums of angle products need N <= 1024");

/* 1.4826 = 1/Φ⁻¹(3/4): σ ≈ 1.4826·MAD for Gaussian data, in Q16. */
#define MAD_TO_SIGMA_Q16 97163

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
    window_clear(w);
    return WINDOW_OK;
}

void window_clear(struct window_state *w) {
    w->oldest = 0;
    w->fill = 0;
    memset(&w->sums, 0, sizeof w->sums);
}

static void axis_contrib(struct window_axis_sums *s, const fix_udeg_t angle[ANGLES_PER_AXIS],
                         uint8_t valid, bool complete, int sign) {
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if ((valid & (1u << i)) != 0u) {
            s->sum[i] += sign * (int64_t)angle[i];
            s->count[i] = (uint16_t)(s->count[i] + sign);
        }
    }
    if (!complete) {
        return;
    }
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        s->complete_sum[i] += sign * (int64_t)angle[i];
        for (unsigned j = i; j < ANGLES_PER_AXIS; ++j) {
            s->complete_prod[window_pair_index(i, j)] +=
                sign * ((int64_t)angle[i] * (int64_t)angle[j]);
        }
    }
}

/* Adds (sign +1) or removes (sign −1) the readings of row selected by mask. */
static void contrib(struct window_sums *s, const struct window_row *row, uint8_t mask,
                    int32_t arm_um, int sign) {
    if (mask == 0u) {
        return;
    }
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        if ((mask & (1u << k)) != 0u) {
            const uint32_t x = row->range_mm[k];
            if (sign > 0) {
                s->sum_mm[k] += x;
                s->sum_sq_mm2[k] += (uint64_t)x * x;
                s->count[k]++;
            } else {
                s->sum_mm[k] -= x;
                s->sum_sq_mm2[k] -= (uint64_t)x * x;
                s->count[k]--;
            }
        }
    }
    struct angles_sample a;
    angles_compute(row->range_mm, mask, arm_um, &a);
    axis_contrib(&s->alpha, a.alpha_udeg, a.alpha_valid, a.flatness_valid, sign);
    axis_contrib(&s->beta, a.beta_udeg, a.beta_valid, a.flatness_valid, sign);
    if (a.flatness_valid) {
        s->complete = (uint16_t)(s->complete + sign);
        s->residual_sum_mm += sign * (int64_t)a.flatness_mm;
    }
}

void window_push(struct window_state *w, const uint16_t range_mm[ANGLES_SENSORS],
                 uint8_t present_mask, uint8_t valid_mask) {
    if (w->fill >= w->cfg.length) {
        const struct window_row *old = &w->ring[w->oldest];
        contrib(&w->sums, old, old->valid, w->cfg.arm_um, -1);
        w->oldest = (uint16_t)((w->oldest + 1u) % w->cfg.length);
        w->fill--;
    }
    const uint16_t slot = (uint16_t)((w->oldest + w->fill) % w->cfg.length);
    struct window_row *row = &w->ring[slot];
    memcpy(row->range_mm, range_mm, sizeof row->range_mm);
    row->present = (uint8_t)(present_mask & ANGLES_ALL_SENSORS);
    row->valid = (uint8_t)(valid_mask & row->present);
    row->aux = 0;
    w->fill++;
    contrib(&w->sums, row, row->valid, w->cfg.arm_um, +1);
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

/* --- the gate ------------------------------------------------------------------ */

/* Rows whose valid reading of sensor k, as 2x - centre_x2 in absolute value when
 * use_dev, else as x, is <= v. */
static uint16_t count_le(const struct window_state *w, unsigned k, bool use_dev, int32_t centre_x2,
                         int32_t v) {
    uint16_t n = 0;
    for (uint16_t r = 0; r < w->fill; ++r) {
        const struct window_row *row = &w->ring[(w->oldest + r) % w->cfg.length];
        if ((row->valid & (1u << k)) == 0u) {
            continue;
        }
        int32_t x = row->range_mm[k];
        if (use_dev) {
            x = 2 * x - centre_x2;
            x = x < 0 ? -x : x;
        }
        if (x <= v) {
            n++;
        }
    }
    return n;
}

/* The order statistic of rank `rank` (0-based) by bisection on [0, hi]: the
 * smallest v with more than `rank` values <= v. ceil(log2(hi + 1)) passes. */
static int32_t select_rank(const struct window_state *w, unsigned k, bool use_dev,
                           int32_t centre_x2, uint16_t rank, int32_t hi) {
    int32_t lo = 0;
    for (unsigned step = 0; step < 18u && lo < hi; ++step) {
        const int32_t mid = lo + (hi - lo) / 2;
        if (count_le(w, k, use_dev, centre_x2, mid) > rank) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    return lo;
}

/* Gate of sensor k: fills median and half-width (both x2 mm). Returns false
 * when the gate is off or there is nothing to gate. */
static bool gate_sensor(const struct window_state *w, unsigned k, uint16_t valid_count,
                        int32_t *median_x2, int32_t *half_width_x2) {
    *median_x2 = 0;
    *half_width_x2 = 0;
    if (w->cfg.gate_sigmas_q8 == 0u || valid_count == 0u) {
        return false;
    }
    const uint16_t lo_rank = (uint16_t)((valid_count - 1u) / 2u);
    const uint16_t hi_rank = (uint16_t)(valid_count / 2u);
    const int32_t x_lo = select_rank(w, k, false, 0, lo_rank, 65535);
    const int32_t x_hi = hi_rank == lo_rank ? x_lo : select_rank(w, k, false, 0, hi_rank, 65535);
    *median_x2 = x_lo + x_hi;
    /* MAD as the lower median of the deviations, in the same x2 units. */
    const int32_t mad_x2 = select_rank(w, k, true, *median_x2, lo_rank, 131071);
    const int64_t scaled = ((int64_t)mad_x2 * MAD_TO_SIGMA_Q16 * w->cfg.gate_sigmas_q8) >> 24;
    const int64_t floor_x2 = 2 * (int64_t)w->cfg.gate_floor_mm;
    *half_width_x2 = (int32_t)(scaled > floor_x2 ? scaled : floor_x2);
    return true;
}

/* --- statistics from sums ---------------------------------------------------------- */

static fix_udeg_q16_t mean_q16(int64_t sum, uint16_t n) {
    return n == 0u ? 0 : fix_div_round_s64(sum * (int64_t)(1 << FIX_UDEG_Q_SHIFT), n);
}

static void axis_stats(const struct window_axis_sums *s, uint16_t complete,
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
                c = fix_s128_div_s64(num, (int64_t)complete * (complete - 1), NULL);
            }
            out->cov[i][j] = c;
            out->cov[j][i] = c;
        }
    }
}

void window_compute(struct window_state *w, struct window_stats *out) {
    memset(out, 0, sizeof *out);
    out->rows = w->fill;
    struct window_sums *g = &w->gated;
    *g = w->sums;

    int32_t median_x2[ANGLES_SENSORS];
    int32_t half_x2[ANGLES_SENSORS];
    bool gate_on[ANGLES_SENSORS];
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        gate_on[k] = gate_sensor(w, k, w->sums.count[k], &median_x2[k], &half_x2[k]);
        out->sensor[k].median_x2_mm = median_x2[k];
        out->sensor[k].gate_x2_mm = half_x2[k];
    }

    for (uint16_t r = 0; r < w->fill; ++r) {
        const struct window_row *row = &w->ring[(w->oldest + r) % w->cfg.length];
        uint8_t rejected = 0;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            const uint8_t bit = (uint8_t)(1u << k);
            struct window_sensor_stats *ss = &out->sensor[k];
            if ((row->present & bit) == 0u) {
                ss->missing++;
            } else if ((row->valid & bit) == 0u) {
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
            contrib(g, row, row->valid, w->cfg.arm_um, -1);
            contrib(g, row, (uint8_t)(row->valid & ~rejected), w->cfg.arm_um, +1);
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
            ss->var_mm2 =
                fix_s128_div_s64(fix_s128_shl(num, FIX_Q32_SHIFT), (int64_t)n * (n - 1), NULL);
        }
    }
    out->complete = g->complete;
    axis_stats(&g->alpha, g->complete, &out->alpha);
    axis_stats(&g->beta, g->complete, &out->beta);
    if (g->complete > 0u) {
        out->residual_valid = true;
        out->residual_um = fix_sat_s32(fix_div_round_s64(g->residual_sum_mm * 1000, g->complete));
    }
}
