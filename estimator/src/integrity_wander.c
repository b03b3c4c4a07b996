/* The offsets' prior walk, and how much of it (and of the stability prior) the parity allows. */
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

/* The prior walk's variance at rows since the start: offset_walk (µm²/h) · rows · period
 * (µs) / 3.6e9 µs/h, in µm², then as Q32 mm² (saturating: it grows, it is never capped). */
fix_q32_t integrity_prior_walk(const struct integrity_config *cfg, uint32_t rows) {
    bool sat = false;
    const int64_t us = (int64_t)rows * (int64_t)cfg->period_us;
    const int64_t um2 = fix_muldiv_s64(us, (int64_t)cfg->offset_walk_um2_h, 3600000000, &sat);
    const int64_t q32 = fix_muldiv_s64(um2, FIX_Q32_ONE, 1000000, &sat);
    return sat ? INT64_MAX : q32;
}

/* The scale (Q16, at most 1) from the spans so far. */
static uint32_t wander_scale(const struct integrity_wander *w, const struct integrity_config *cfg) {
    /* what the prior walk predicts for ΣD²: 4 · (2/3) · r · ΣT (the walk over ΣT, · 8/3) */
    const fix_q32_t prior = fix_muldiv_s64(integrity_prior_walk(cfg, w->prior_rows), 8, 3, NULL);
    if (w->n < WANDER_MIN_SPANS || prior <= 0) {
        return 65536u;
    }
    const fix_q32_t excess = w->excess;
    const fix_q32_t v = fix_sat_add_s64(w->white, excess > 0 ? excess : 0);
    /* √(3/n) in Q16: each D² has variance 2·V², and consecutive D share a span mean
     * (correlation −1/2, so their squares' covariance V²/2): Var ΣD² ≈ 3n·V² */
    const uint64_t root2n = (uint64_t)fix_isqrt_u64(0xC0000000u / w->n) << 1u; /* Q15 -> Q16 */
    const fix_q32_t margin =
        fix_mul_shr_s64(v, (int64_t)root2n * WANDER_K, 16u, NULL); /* k·√(3/n)·Σ V */
    const fix_q32_t bound = fix_sat_add_s64(excess, margin);
    if (bound >= prior) {
        return 65536u;
    }
    return bound <= 0 ? 0u : (uint32_t)fix_muldiv_s64(bound, 65536, prior, NULL);
}

void integrity_wander_add(struct integrity_wander *w, const struct integrity_config *cfg,
                          uint32_t rows_now, fix_q32_t parity_mm, fix_q32_t white_mm2) {
    /* |parity| < 2^15 mm (four readings below 8191 mm), Q32, over at most 65535 blocks: no
     * saturation needed; the white variances can be large, and saturate */
    w->sum_mm += parity_mm;
    w->sum_w = fix_sat_add_s64(w->sum_w, white_mm2);
    w->blocks++;
    /* rows since the previous span's end: the distance between the two spans' centres */
    const uint32_t rows = rows_now - w->end;
    /* a minute, or an eighth of the time since the start when longer: the walk's share of
     * D² grows as T and the white share falls as 1/T, so the longer spans of a long run
     * keep the bound falling as the walk it scales grows (a fixed minute left it at 0.48
     * of the error at σ = 1 mm after half an hour: its margin falls as 1/√n, the walk
     * grows as t) */
    const uint32_t span_min = WANDER_SPAN_US / cfg->period_us;
    const uint32_t span_rows = rows_now / 8u > span_min ? rows_now / 8u : span_min;
    if (rows < span_rows && w->blocks < UINT16_MAX) {
        return;
    }
    /* the span's mean and the white variance of that mean */
    const int32_t b = w->blocks;
    const fix_q32_t mean = fix_div_round_s64(w->sum_mm, b);
    const fix_q32_t wm = integrity_div_small(integrity_div_small(w->sum_w, b), b);
    if (w->end != 0u) { /* a previous span: one closes only at rows >= a minute's */
        const fix_q32_t d = mean - w->prev_mm;
        const fix_q32_t d2 = fix_mul_shr_s64(d, d, FIX_Q32_SHIFT, NULL);
        const fix_q32_t white = fix_sat_add_s64(w->prev_w, wm);
        w->excess = fix_sat_add_s64(w->excess, d2 - white);
        w->white = fix_sat_add_s64(w->white, white);
        /* adjacent means over spans T1, T2 of a walk differ by r·(T1 + T2)/3 */
        w->prior_rows += (rows + w->prev_rows) / 2u;
        w->n++; /* one a span of a minute or more: 2^32 of them is 8000 years */
        w->cut_q16 = 65536u - wander_scale(w, cfg);
    }
    w->end = rows_now;
    w->prev_rows = rows;
    w->prev_mm = mean;
    w->prev_w = wm;
    w->blocks = 0;
    w->sum_mm = 0;
    w->sum_w = 0;
}

fix_q32_t integrity_wander_scaled(const struct integrity_wander *w, fix_q32_t prior_mm2) {
    return prior_mm2 - fix_mul_shr_s64(prior_mm2, (int64_t)w->cut_q16, 16u, NULL);
}
