/* The window's gate: each sensor's median and MAD from the ring, by counting bisection. */
#include "estimator/window_stats.h"

#include <string.h>

#include "fixmath_internal.h"
#include "window_internal.h"

/* 1.4826 = 1/Φ⁻¹(3/4): σ ≈ 1.4826·MAD for Gaussian data, in Q16. */
#define MAD_TO_SIGMA_Q16 97163

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

void window_gate_sensors(const struct window_state *w, const uint16_t count[ANGLES_SENSORS],
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
