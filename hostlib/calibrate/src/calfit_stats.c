/* The fit's statistics: autocorrelation time and weighted least squares (calfit.h). */
#include "calibrate/calfit.h"

#include <math.h>

double calfit_tau(const struct calfit_data *d, unsigned k, bool *settled) {
    /* Sokal, "Monte Carlo methods in statistical mechanics" (1997), §3: the integrated
     * autocorrelation time τ = 1 + 2 Σ ρ_t summed over a window M, the smallest with
     * M >= 5 τ(M), which keeps the estimate's bias and variance both small. The
     * autocovariances are pooled over the stations, each reading taken about its own
     * station's mean, lags never crossing from one station into the next. */
    const double *r = d->readings[k];
    double c0 = 0.0;
    uint32_t longest = 0;
    double total = 0.0;
    double stations = 0.0;
    for (size_t j = 0; j < d->n_stations; ++j) {
        const struct calfit_station *st = &d->stations[j];
        if (!st->used[k]) {
            continue;
        }
        for (uint32_t t = 0; t < st->n[k]; ++t) {
            const double e = r[st->first[k] + t] - st->mean_mm[k];
            c0 += e * e;
        }
        longest = st->n[k] > longest ? st->n[k] : longest;
        total += st->n[k];
        stations += 1.0;
    }
    *settled = true;
    if (!(c0 > 0.0)) {
        return 1.0; /* no scatter at all: nothing is correlated */
    }
    uint32_t max_lag = longest / 2u;
    max_lag = max_lag > CALFIT_MAX_LAG ? CALFIT_MAX_LAG : max_lag;
    double sum = 0.0;
    double tau = 1.0;
    *settled = false;
    for (uint32_t lag = 1; lag <= max_lag; ++lag) {
        double c = 0.0;
        for (size_t j = 0; j < d->n_stations; ++j) {
            const struct calfit_station *st = &d->stations[j];
            if (!st->used[k] || st->n[k] <= lag) {
                continue;
            }
            const double *s = r + st->first[k];
            const double m = st->mean_mm[k];
            for (uint32_t t = 0; t + lag < st->n[k]; ++t) {
                c += (s[t] - m) * (s[t + lag] - m);
            }
        }
        sum += c / c0;
        /* Each station's readings are taken about its own mean, whose error is correlated
         * with them: every autocovariance is low by about var(mean) = σ²τ/n, so the sum
         * over the 2M + 1 lags of the window is low by τ(2M + 1)/n (Sokal 1997, §3;
         * Priestley 1981, §5.3). Corrected here with n the stations' mean length; a
         * window that reaches half of it is too long to trust. */
        const double shrink = 1.0 - (2.0 * lag + 1.0) / (total / stations);
        if (shrink < 0.5) {
            break;
        }
        tau = (1.0 + 2.0 * sum) / shrink;
        if ((double)lag >= 5.0 * tau) {
            *settled = true;
            break;
        }
    }
    /* Floored at 1: a negative correlation would shrink the sd, and white noise's
     * estimate scatters on both sides of 1; the floor errs on the safe side. */
    return tau > 1.0 ? tau : 1.0;
}

int calfit_wls(const double *x, const double *y, const double *w, size_t n, unsigned p,
               double coef[2], double cov[3]) {
    double s = 0.0;
    double sx = 0.0;
    double sy = 0.0;
    for (size_t i = 0; i < n; ++i) {
        s += w[i];
        sx += w[i] * x[i];
        sy += w[i] * (y[i] - (p == 1u ? x[i] : 0.0));
    }
    if (!(s > 0.0)) {
        return -1;
    }
    if (p == 1u) {
        /* y = x + offset: the weighted mean of y − x. */
        coef[0] = sy / s;
        coef[1] = 1.0;
        cov[0] = 1.0 / s;
        cov[1] = 0.0;
        cov[2] = 0.0;
        return 0;
    }
    /* Centred about the weighted mean of x, so the sums do not cancel. */
    const double xm = sx / s;
    const double ym = sy / s;
    double sxx = 0.0;
    double sxy = 0.0;
    for (size_t i = 0; i < n; ++i) {
        sxx += w[i] * (x[i] - xm) * (x[i] - xm);
        sxy += w[i] * (x[i] - xm) * (y[i] - ym);
    }
    if (!(sxx > 1e-18 * s * (1.0 + xm * xm))) {
        return -1; /* every x the same: the gain is not determined */
    }
    coef[1] = sxy / sxx;
    coef[0] = ym - coef[1] * xm;
    cov[2] = 1.0 / sxx;
    cov[1] = -xm / sxx;
    cov[0] = 1.0 / s + xm * xm / sxx;
    return 0;
}

int calfit_wls_general(const double *f, const double *y, const double *w, size_t n, unsigned p,
                       double *coef, double *cov) {
    if (p == 0u || p > CALFIT_WLS_MAX_P || n < p) {
        return -1;
    }
    /* The normal equations [M | I] reduced by Gauss–Jordan with partial pivoting. */
    enum { P = CALFIT_WLS_MAX_P };
    double a[P][2 * P] = {{0}};
    double v[P] = {0};
    for (size_t i = 0; i < n; ++i) {
        const double *fi = f + i * p;
        for (unsigned r = 0; r < p; ++r) {
            v[r] += w[i] * fi[r] * y[i];
            for (unsigned c = 0; c < p; ++c) {
                a[r][c] += w[i] * fi[r] * fi[c];
            }
        }
    }
    double scale = 0.0;
    for (unsigned r = 0; r < p; ++r) {
        a[r][p + r] = 1.0;
        scale = fabs(a[r][r]) > scale ? fabs(a[r][r]) : scale;
    }
    for (unsigned c = 0; c < p; ++c) {
        unsigned piv = c;
        for (unsigned r = c + 1u; r < p; ++r) {
            piv = fabs(a[r][c]) > fabs(a[piv][c]) ? r : piv;
        }
        if (!(fabs(a[piv][c]) > 1e-12 * scale)) {
            return -1; /* a feature is a combination of the others: not determined */
        }
        for (unsigned k = 0; k < 2u * p; ++k) {
            const double t = a[c][k];
            a[c][k] = a[piv][k];
            a[piv][k] = t;
        }
        const double d = a[c][c];
        for (unsigned k = 0; k < 2u * p; ++k) {
            a[c][k] /= d;
        }
        for (unsigned r = 0; r < p; ++r) {
            if (r == c) {
                continue;
            }
            const double m = a[r][c];
            for (unsigned k = 0; k < 2u * p; ++k) {
                a[r][k] -= m * a[c][k];
            }
        }
    }
    for (unsigned r = 0; r < p; ++r) {
        coef[r] = 0.0;
        for (unsigned c = 0; c < p; ++c) {
            cov[r * p + c] = a[r][p + c];
            coef[r] += a[r][p + c] * v[c];
        }
    }
    return 0;
}
