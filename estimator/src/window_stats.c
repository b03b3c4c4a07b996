/* Window sums, gate and statistics: see estimator/window_stats.h. */
#include "estimator/window_stats.h"

#include <string.h>

#include "fixmath_internal.h"
#include "window_internal.h"

_Static_assert(WINDOW_MAX_SAMPLES >= 255u, "windows of at least 255 rows are required");
_Static_assert(WINDOW_MAX_SAMPLES <= 1024u, "exact 64-bit sums of angle products need N <= 1024");
_Static_assert(sizeof(struct window_row) == 10u, "a window row is 10 bytes (the RAM budget)");

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
    angles_arm_prepare(&w->arm, cfg->arm_um);
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        /* µm as fine units: · 1024/1000; 1/gain − 1 = −ppm/(10^6 + ppm), in Q32 (|.| < 2^31
         * for gains within ±10 %); all exactly 0 for an identity calibration */
        w->cal_offset_fine[k] = (int32_t)fix_div_round_s64((int64_t)cfg->offset_um[k] * 128, 125);
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

/* Four bisections at once, one counting pass over the ring per step for all of them:
 * sensor k (a bit of `active`) searches [lo[k], hi[k]], which must hold it, for the
 * order statistic of rank rank[k] (0-based) of its valid readings, x or |2x − centre[k]|
 * when use_dev: the smallest v with more than rank[k] values <= v. ceil(log2(range + 1))
 * steps (at most 18: every range is below 2^17). lo[] receives the answers. */
static void select_ranks(const struct window_state *w, uint8_t active, bool use_dev,
                         const int32_t centre[ANGLES_SENSORS], const uint16_t rank[ANGLES_SENSORS],
                         int32_t lo[ANGLES_SENSORS], int32_t hi[ANGLES_SENSORS]) {
    for (unsigned step = 0; step < 18u; ++step) {
        uint8_t todo = 0;
        int32_t mid[ANGLES_SENSORS] = {0, 0, 0, 0};
        uint16_t n[ANGLES_SENSORS] = {0, 0, 0, 0};
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            if ((active & (1u << k)) != 0u && lo[k] < hi[k]) {
                todo = (uint8_t)(todo | (1u << k));
                mid[k] = lo[k] + (hi[k] - lo[k]) / 2;
            }
        }
        if (todo == 0u) {
            break;
        }
        uint16_t idx = w->oldest;
        for (uint16_t r = 0; r < w->fill; ++r) {
            const struct window_row *row = &w->ring[idx];
            idx = (uint16_t)(idx + 1u == w->cfg.length ? 0u : idx + 1u);
            const uint8_t m = (uint8_t)(window_row_valid(row) & todo);
            for (unsigned k = 0; k < ANGLES_SENSORS && m != 0u; ++k) {
                if ((m & (1u << k)) != 0u) {
                    int32_t x = row->range_mm[k];
                    if (use_dev) {
                        x = 2 * x - centre[k];
                        x = x < 0 ? -x : x;
                    }
                    n[k] = (uint16_t)(n[k] + (x <= mid[k] ? 1u : 0u));
                }
            }
        }
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            if ((todo & (1u << k)) != 0u) {
                if (n[k] > rank[k]) {
                    hi[k] = mid[k];
                } else {
                    lo[k] = mid[k] + 1;
                }
            }
        }
    }
}

/* Histogram orders: readings of one sensor spanning at most HIST_BINS values and at most
 * 255 of them (uint8 counts) are counted once into bins and the medians and the MAD read
 * off; wider or more readings go to the bisections (the same answers, more passes). */
#ifndef HIST_BINS
#define HIST_BINS 256u
#endif

/* Median (lower, upper) and MAD (x2 mm) of sensor k from a histogram of its valid
 * readings in [x_min, x_min + HIST_BINS). Same definitions as select_ranks(). */
FIX_NOINLINE void hist_gate(const struct window_state *w, unsigned k, int32_t x_min, int32_t x_max,
                            uint16_t lo_rank, uint16_t hi_rank, int32_t *median_x2,
                            int32_t *mad_x2) {
    uint8_t hist[HIST_BINS];
    (void)memset(hist, 0, sizeof hist);
    uint16_t idx = w->oldest;
    for (uint16_t r = 0; r < w->fill; ++r) {
        const struct window_row *row = &w->ring[idx];
        idx = (uint16_t)(idx + 1u == w->cfg.length ? 0u : idx + 1u);
        if ((window_row_valid(row) & (1u << k)) != 0u) {
            const int32_t offset = (int32_t)row->range_mm[k] - x_min; /* >= 0 */
            const uint32_t bin = (uint32_t)offset;
            hist[bin] = (uint8_t)(hist[bin] + 1u);
        }
    }
    const int32_t span_signed = x_max - x_min;
    const uint32_t span = (uint32_t)span_signed; /* < HIST_BINS */
    /* the medians: the smallest values with more than rank readings at or below */
    uint32_t cum = 0;
    int32_t x_lo = x_max;
    int32_t x_hi = x_max;
    bool lo_found = false;
    for (uint32_t b = 0; b <= span; ++b) {
        cum += hist[b];
        if (!lo_found && cum > lo_rank) {
            x_lo = x_min + (int32_t)b;
            lo_found = true;
        }
        if (cum > hi_rank) {
            x_hi = x_min + (int32_t)b;
            break;
        }
    }
    const int32_t m2 = x_lo + x_hi;
    *median_x2 = m2;
    /* the MAD: deviations |2x − m2| in increasing order, x walking away from m2/2 on both
     * sides (each step 2); the first deviation with more than lo_rank readings within */
    int32_t xl = m2 / 2 - ((m2 % 2 == 0) ? 1 : 0); /* left: deviation m2 − 2 xl */
    int32_t xr = m2 - m2 / 2;                      /* right: deviation 2 xr − m2 */
    cum = 0;
    int32_t mad = 0;
    for (uint32_t step = 0; step <= 2u * HIST_BINS; ++step) {
        const bool l_in = xl >= x_min;
        const bool r_in = xr <= x_max;
        if (!l_in && !r_in) {
            break; /* unreachable: the readings number more than lo_rank */
        }
        const int32_t dl = m2 - 2 * xl;
        const int32_t dr = 2 * xr - m2;
        const bool take_l = l_in && (!r_in || dl <= dr);
        const bool take_r = r_in && (!l_in || dr <= dl);
        const int32_t d = take_l ? dl : dr;
        if (take_l) {
            const int32_t bin_l = xl - x_min;
            cum += hist[(uint32_t)bin_l];
            --xl;
        }
        if (take_r) {
            const int32_t bin_r = xr - x_min;
            cum += hist[(uint32_t)bin_r];
            ++xr;
        }
        if (cum > lo_rank) {
            mad = d;
            break;
        }
    }
    *mad_x2 = mad;
}

/* The medians and MAD (x2 mm) of the sensors in `bisect` by bisection over their value
 * ranges [x_min, x_max] (upper medians only for those in `even`): the sensors whose
 * readings a histogram cannot hold. Same definitions as hist_gate(). */
static void bisect_gate(const struct window_state *w, uint8_t bisect, uint8_t even,
                        const int32_t x_min[ANGLES_SENSORS], const int32_t x_max[ANGLES_SENSORS],
                        const uint16_t lo_rank[ANGLES_SENSORS],
                        const uint16_t hi_rank[ANGLES_SENSORS], int32_t median_x2[ANGLES_SENSORS],
                        int32_t mad_x2[ANGLES_SENSORS]) {
    const int32_t none[ANGLES_SENSORS] = {0, 0, 0, 0};
    int32_t x_lo[ANGLES_SENSORS];
    int32_t x_hi[ANGLES_SENSORS];
    int32_t top[ANGLES_SENSORS];
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        x_lo[k] = x_min[k];
        top[k] = x_max[k];
    }
    select_ranks(w, bisect, false, none, lo_rank, x_lo, top); /* lower medians */
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        x_hi[k] = x_lo[k];
        top[k] = x_max[k];
    }
    select_ranks(w, even, false, none, hi_rank, x_hi, top); /* upper medians (even n) */
    /* MAD as the lower median of the deviations, in the same x2 units: every
     * deviation |2x − median_x2| lies in [0, 2 (x_max − x_min)] */
    int32_t centre[ANGLES_SENSORS];
    int32_t mad[ANGLES_SENSORS];
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        centre[k] = x_lo[k] + x_hi[k];
        mad[k] = 0;
        top[k] = 2 * (x_max[k] - x_min[k]);
    }
    select_ranks(w, bisect, true, centre, lo_rank, mad, top);
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        if ((bisect & (1u << k)) != 0u) {
            median_x2[k] = centre[k];
            mad_x2[k] = mad[k];
        }
    }
}

/* The gate of every sensor with valid readings: median and half-width (both x2 mm) and
 * whether the gate applies (off, or nothing to gate: false). */
static void gate_sensors(const struct window_state *w, const uint16_t count[ANGLES_SENSORS],
                         int32_t median_x2[ANGLES_SENSORS], int32_t half_width_x2[ANGLES_SENSORS],
                         bool gate_on[ANGLES_SENSORS]) {
    uint8_t active = 0;
    int32_t x_min[ANGLES_SENSORS] = {65535, 65535, 65535, 65535};
    int32_t x_max[ANGLES_SENSORS] = {0, 0, 0, 0};
    uint16_t lo_rank[ANGLES_SENSORS] = {0, 0, 0, 0};
    uint16_t hi_rank[ANGLES_SENSORS] = {0, 0, 0, 0};
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        median_x2[k] = 0;
        half_width_x2[k] = 0;
        gate_on[k] = w->cfg.gate_sigmas_q8 != 0u && count[k] != 0u;
        if (gate_on[k]) {
            active = (uint8_t)(active | (1u << k));
            lo_rank[k] = (uint16_t)((count[k] - 1u) / 2u);
            hi_rank[k] = (uint16_t)(count[k] / 2u);
        }
    }
    if (active == 0u) {
        return;
    }
    /* smallest and largest valid reading of each sensor: the medians lie between */
    uint16_t idx = w->oldest;
    for (uint16_t r = 0; r < w->fill; ++r) {
        const struct window_row *row = &w->ring[idx];
        idx = (uint16_t)(idx + 1u == w->cfg.length ? 0u : idx + 1u);
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            if ((window_row_valid(row) & active & (1u << k)) != 0u) {
                const int32_t x = row->range_mm[k];
                x_min[k] = x < x_min[k] ? x : x_min[k];
                x_max[k] = x > x_max[k] ? x : x_max[k];
            }
        }
    }
    int32_t mad_x2[ANGLES_SENSORS] = {0, 0, 0, 0};
    uint8_t bisect = 0;
    uint8_t even = 0;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        if ((active & (1u << k)) == 0u) {
            continue;
        }
        if (x_max[k] - x_min[k] < (int32_t)HIST_BINS && count[k] <= 255u) {
            hist_gate(w, k, x_min[k], x_max[k], lo_rank[k], hi_rank[k], &median_x2[k], &mad_x2[k]);
        } else {
            bisect = (uint8_t)(bisect | (1u << k));
            if (hi_rank[k] != lo_rank[k]) {
                even = (uint8_t)(even | (1u << k));
            }
        }
    }
    if (bisect != 0u) {
        bisect_gate(w, bisect, even, x_min, x_max, lo_rank, hi_rank, median_x2, mad_x2);
    }
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        if (gate_on[k]) {
            /* Whole-mm readings put the MAD within 1/2 mm of the noise's (it reads 1 mm at
             * σ 2 mm: a gate of 5·1.4826·1 mm rejected a good sensor in up to 17 % of clean
             * windows): the scale takes MAD + 1/2 mm (x2: + 1), widened by (n + 8)/n for a
             * short window's own scatter (relative sd about 1.2/√n). */
            const uint64_t mad_q = ((uint64_t)mad_x2[k] + 1u) * ((uint64_t)count[k] + 8u);
            const int64_t mad_n = (int64_t)fix_div_u64_u16(mad_q << 8, count[k]); /* Q8 */
            const int64_t scaled = (mad_n * MAD_TO_SIGMA_Q16 * w->cfg.gate_sigmas_q8) >> 32;
            const int64_t floor_x2 = 2 * (int64_t)w->cfg.gate_floor_mm;
            half_width_x2[k] = (int32_t)(scaled > floor_x2 ? scaled : floor_x2);
        }
    }
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
    gate_sensors(w, w->sums.count, median_x2, half_x2, gate_on);
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
