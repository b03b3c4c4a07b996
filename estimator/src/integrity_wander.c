/* How much of the offsets' prior wander the parity's minute-scale means allow. */
#include "integrity_internal.h"

/*
 * The drift allowance rests on two priors measured on one real VL53L0X (attitude.h: the
 * offset stability, 120 µm, and the walk, 576 000 µm²/h), because three of the four offset
 * directions cannot be seen at a static plate. The fourth can: the parity residual
 * x_A + x_C − x_B − x_D moves only with the offsets (and with the calibration's gain error
 * when the plate moves, which only raises what is learnt here). By the isotropy assumption
 * (each offset wanders alike and independently: docs/estimator-design.md, "Drift since the
 * start") the parity's wander is that of any one offset, four times over. So the priors are
 * scaled by what the parity shows, downward only: a head that wanders less than the log
 * (a simulated one, or a part quieter than that VL53L0X) gets the sd its data support,
 * one that wanders as much or more keeps the priors (and the learnt drift above them).
 *
 * The measure: the parity averaged over spans of WANDER_SPAN_US; consecutive span means
 * differ by D, whose square beyond the two means' white variances is, under the prior walk
 * r, 4·r·(2/3)·T (adjacent means of a random walk over spans T) in expectation. The scale is
 * an upper bound on the ratio of the two: (Σ(D² − w) + k·√(3/n)·Σ max(D², w)) / Σ 4·(2/3)·r·T
 * over the n span pairs so far (the sum's sd, below, at k = 3 one-sided),
 * at most 1, and 1 until WANDER_MIN_SPANS. A minute: at the prior rate the walk's share of
 * D² passes the white share of a σ = 2 mm, N = 100 window's parity from about 22 s on.
 */
#define WANDER_SPAN_US   60000000u
#define WANDER_MIN_SPANS 3u
#define WANDER_K         3

/* The prior walk's expected D² over one span of `rows` rows: 4 · (2/3) · r · T, Q32 mm². */
static fix_q32_t prior_d2(const struct integrity_config *cfg, uint32_t rows) {
    bool sat = false;
    const int64_t us = (int64_t)rows * (int64_t)cfg->period_us;
    /* µm² = r [µm²/h] · us / 3.6e9, times 8/3 */
    const int64_t um2 = fix_muldiv_s64(us, (int64_t)cfg->offset_walk_um2_h * 8, 10800000000, &sat);
    const int64_t q32 = fix_muldiv_s64(um2, FIX_Q32_ONE, 1000000, &sat);
    return sat ? INT64_MAX : q32;
}

/* The scale (Q16, at most 1) from the spans so far. */
static uint32_t wander_scale(const struct integrity_state *st) {
    if (st->wander_n < WANDER_MIN_SPANS || st->wander_prior <= 0) {
        return 65536u;
    }
    const fix_q32_t excess = st->wander_sum;
    const fix_q32_t v = fix_sat_add_s64(st->wander_white, excess > 0 ? excess : 0);
    /* √(3/n) in Q16: each D² has variance 2·V², and consecutive D share a span mean
     * (correlation −1/2, so their squares' covariance V²/2): Var ΣD² ≈ 3n·V² */
    const uint64_t root2n = fix_isqrt_u64(((uint64_t)3 << 32) / st->wander_n);
    const fix_q32_t margin =
        fix_mul_shr_s64(v, (int64_t)root2n * WANDER_K, 16u, NULL); /* k·√(2/n)·Σ V */
    const fix_q32_t bound = fix_sat_add_s64(excess, margin);
    if (bound >= st->wander_prior) {
        return 65536u;
    }
    return bound <= 0 ? 0u : (uint32_t)fix_muldiv_s64(bound, 65536, st->wander_prior, NULL);
}

void integrity_wander_add(struct integrity_state *st, const struct integrity_config *cfg,
                          fix_q32_t parity_mm, fix_q32_t white_mm2) {
    st->span_sum_mm = fix_sat_add_s64(st->span_sum_mm, parity_mm);
    st->span_sum_w = fix_sat_add_s64(st->span_sum_w, white_mm2);
    st->span_blocks++;
    /* rows since the previous span's end: the distance between the two spans' centres */
    const uint32_t rows = st->rows - st->span_end;
    /* a minute, or an eighth of the time since the start when longer: the walk's share of
     * D² grows as T and the white share falls as 1/T, so the longer spans of a long run
     * keep the bound falling as the walk it scales grows (a fixed minute left it at 0.48
     * of the error at σ = 1 mm after half an hour: its margin falls as 1/√n, the walk
     * grows as t) */
    const uint32_t span_min = WANDER_SPAN_US / cfg->period_us;
    const uint32_t span_rows = st->rows / 8u > span_min ? st->rows / 8u : span_min;
    if (rows < span_rows && st->span_blocks < UINT16_MAX) {
        return;
    }
    /* the span's mean and the white variance of that mean */
    const int64_t b = st->span_blocks;
    const fix_q32_t mean = fix_div_round_s64(st->span_sum_mm, b);
    const fix_q32_t w = fix_div_round_s64(st->span_sum_w, b * b);
    if (st->span_prev) {
        const fix_q32_t d2 = integrity_square_q32(mean - st->span_prev_mm);
        const fix_q32_t white = fix_sat_add_s64(st->span_prev_w, w);
        st->wander_sum = fix_sat_add_s64(st->wander_sum, d2 - white);
        st->wander_white = fix_sat_add_s64(st->wander_white, white);
        /* adjacent means over spans T1, T2 of a walk differ by r·(T1 + T2)/3 */
        st->wander_prior =
            fix_sat_add_s64(st->wander_prior, prior_d2(cfg, (rows + st->span_prev_rows) / 2u));
        if (st->wander_n < UINT16_MAX) {
            st->wander_n++;
        }
        st->wander_scale_q16 = wander_scale(st);
    }
    st->span_prev = true;
    st->span_end = st->rows;
    st->span_prev_rows = rows;
    st->span_prev_mm = mean;
    st->span_prev_w = w;
    st->span_blocks = 0;
    st->span_sum_mm = 0;
    st->span_sum_w = 0;
}

fix_q32_t integrity_wander_scaled(const struct integrity_state *st, fix_q32_t prior_mm2) {
    if (st->wander_n < WANDER_MIN_SPANS) {
        return prior_mm2;
    }
    return fix_mul_shr_s64(prior_mm2, (int64_t)st->wander_scale_q16, 16u, NULL);
}
